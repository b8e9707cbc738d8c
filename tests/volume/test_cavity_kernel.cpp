// The kernel's Chebyshev centre (volume/cavity_kernel.h), used by tetra's completion path.

#include <cmath>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "volume/cavity_kernel.h"

using frontmesh::volume::CavityPlane;
using frontmesh::volume::kernel_centre;
using V3 = Eigen::Vector3d;

namespace {

/// The six inward planes of the box [lo, hi].
std::vector<CavityPlane> box(const V3& lo, const V3& hi) {
    std::vector<CavityPlane> planes;
    for (int k = 0; k < 3; ++k) {
        V3 n = V3::Zero();
        n[k] = 1.0;
        planes.push_back({n, lo[k]});
        planes.push_back({-n, -hi[k]});
    }
    return planes;
}

double margin(const std::vector<CavityPlane>& planes, const V3& p) {
    double t = 1e300;
    for (const CavityPlane& c : planes) t = std::min(t, c.n.dot(p) - c.b);
    return t;
}

}  // namespace

TEST_CASE("the kernel centre of a box is its centre, the margin half its shortest side",
          "[volume][kernel]") {
    const auto planes = box(V3(0, 0, 0), V3(4, 2, 8));
    const auto k = kernel_centre(planes, V3(3, 1, 1), 10.0);
    REQUIRE(k.solved);
    CHECK(k.t == Approx(1.0));
    CHECK(k.p.y() == Approx(1.0));
    CHECK(margin(planes, k.p) == Approx(k.t));
}

TEST_CASE("the kernel centre of random convex cavities is the best point", "[volume][kernel]") {
    std::mt19937 rng(7);
    std::normal_distribution<double> g(0.0, 1.0);
    for (int trial = 0; trial < 200; ++trial) {
        // planes tangent to a sphere of radius r around c: the centre is c, the margin r
        const V3 c(g(rng), g(rng), g(rng));
        const double r = 0.5 + std::abs(g(rng));
        std::vector<CavityPlane> planes;
        for (int i = 0; i < 40; ++i) {
            const V3 n = V3(g(rng), g(rng), g(rng)).normalized();
            planes.push_back({-n, -n.dot(c) - r});  // the tangent plane at c + r n, facing c
        }
        const auto k = kernel_centre(planes, c + V3(0.3, -0.2, 0.1), 10.0 * r);
        REQUIRE(k.solved);
        CHECK(k.t >= r * (1.0 - 1e-9));
        CHECK(margin(planes, k.p) == Approx(k.t).margin(1e-9));
        // no sampled point does better than the optimum
        for (int s = 0; s < 20; ++s) {
            const V3 q = k.p + 0.1 * r * V3(g(rng), g(rng), g(rng));
            CHECK(margin(planes, q) <= k.t + 1e-9);
        }
    }
}

TEST_CASE("a cavity with an empty kernel has a negative margin", "[volume][kernel]") {
    // two boxes side by side whose inner walls face away from each other: no point is above
    // all of them
    auto planes = box(V3(0, 0, 0), V3(1, 1, 1));
    const auto other = box(V3(3, 0, 0), V3(4, 1, 1));
    planes.insert(planes.end(), other.begin(), other.end());
    const auto k = kernel_centre(planes, V3(2, 0.5, 0.5), 5.0);
    REQUIRE(k.solved);
    CHECK(k.t < 0.0);
    CHECK(k.t == Approx(-1.0));  // halfway between x = 1 and x = 3
}
