#include <cmath>
#include <numbers>
#include <random>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include "pipeline/core/quality.h"

using namespace frontmesh::core;
using Eigen::Vector3d;

namespace {

const double regular_dihedral_deg = std::acos(1.0 / 3.0) * 180.0 / std::numbers::pi;  // 70.5288

// A regular tetrahedron: alternate corners of a cube.
const Vector3d ra(1, 1, 1), rb(1, -1, -1), rc(-1, 1, -1), rd(-1, -1, 1);

}  // namespace

TEST_CASE("triangle measures on an equilateral triangle", "[core]") {
    const Vector3d a(0, 0, 0), b(2, 0, 0), c(1, std::sqrt(3.0), 0);
    CHECK(triangle_skewness(a, b, c) == Approx(0.0).margin(1e-12));
    CHECK(triangle_min_angle_deg(a, b, c) == Approx(60.0).epsilon(1e-12));
    CHECK(triangle_area(a, b, c) == Approx(std::sqrt(3.0)).epsilon(1e-12));
    // Invariant under rotation, translation, scaling and vertex order.
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(0.7, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    const Vector3d t(10, -20, 5);
    CHECK(triangle_skewness(rotation * c * 1e-3 + t, rotation * a * 1e-3 + t,
                            rotation * b * 1e-3 + t) == Approx(0.0).margin(1e-9));
}

TEST_CASE("triangle measures on a right isosceles and on degenerate triangles", "[core]") {
    const Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
    // Circumradius sqrt(2)/2, equilateral area for it 3 sqrt(3)/8, actual area 1/2.
    CHECK(triangle_skewness(a, b, c) == Approx(1.0 - 4.0 / (3.0 * std::sqrt(3.0))).epsilon(1e-12));
    CHECK(triangle_min_angle_deg(a, b, c) == Approx(45.0).epsilon(1e-12));
    CHECK(triangle_area(a, b, c) == Approx(0.5).epsilon(1e-12));

    CHECK(triangle_skewness(a, b, Vector3d(3, 0, 0)) == 1.0);  // collinear
    CHECK(triangle_skewness(a, a, b) == 1.0);                  // coincident vertices
    CHECK(triangle_skewness(a, a, a) == 1.0);
    CHECK(triangle_min_angle_deg(a, b, Vector3d(3, 0, 0)) == Approx(0.0).margin(1e-12));
    CHECK(triangle_area(a, b, Vector3d(3, 0, 0)) == 0.0);
    // Nearly degenerate: skewness close to 1, ordered by flatness.
    const double s1 = triangle_skewness(a, b, Vector3d(0.5, 1e-2, 0));
    const double s2 = triangle_skewness(a, b, Vector3d(0.5, 1e-4, 0));
    CHECK(s1 < s2);
    CHECK(s2 > 0.999);
    CHECK(s2 <= 1.0);
}

TEST_CASE("tetrahedron measures on a regular tetrahedron", "[core]") {
    CHECK(tet_skewness(ra, rb, rc, rd) == Approx(0.0).margin(1e-12));
    CHECK(tet_min_dihedral_deg(ra, rb, rc, rd) == Approx(regular_dihedral_deg).epsilon(1e-12));
    CHECK(regular_dihedral_deg == Approx(70.5288).epsilon(1e-5));
    // Edge 2 sqrt(2): volume 8/3; the sign follows the orientation.
    const double v = tet_signed_volume(ra, rb, rc, rd);
    CHECK(std::abs(v) == Approx(8.0 / 3.0).epsilon(1e-12));
    CHECK(tet_signed_volume(rb, ra, rc, rd) == Approx(-v).epsilon(1e-12));
    // Skewness and dihedral angles ignore orientation and scale.
    CHECK(tet_skewness(rb, ra, rc, rd) == Approx(0.0).margin(1e-12));
    CHECK(tet_min_dihedral_deg(rb * 1e-4, ra * 1e-4, rc * 1e-4, rd * 1e-4) ==
          Approx(regular_dihedral_deg).epsilon(1e-10));
}

TEST_CASE("tetrahedron measures on the corner tetrahedron", "[core]") {
    const Vector3d o(0, 0, 0), x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
    CHECK(tet_signed_volume(o, x, y, z) == Approx(1.0 / 6.0).epsilon(1e-12));  // z above (o, x, y)
    CHECK(tet_signed_volume(o, y, x, z) == Approx(-1.0 / 6.0).epsilon(1e-12));
    // Circumradius sqrt(3)/2, equilateral volume for it 1/3: skewness 1/2.
    CHECK(tet_skewness(o, x, y, z) == Approx(0.5).epsilon(1e-12));
    // Three right angles at the axes and three of acos(1/sqrt(3)) = 54.7356 deg.
    CHECK(tet_min_dihedral_deg(o, x, y, z) ==
          Approx(std::acos(1.0 / std::sqrt(3.0)) * 180.0 / std::numbers::pi).epsilon(1e-12));
}

TEST_CASE("tetrahedron measures on flat and nearly flat tetrahedra", "[core]") {
    const Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), d(1, 1, 0);
    CHECK(tet_skewness(a, b, c, d) == 1.0);
    CHECK(tet_signed_volume(a, b, c, d) == 0.0);
    // Every ordering of a flat tetrahedron with proper faces has a zero dihedral angle.
    const Vector3d p[4] = {a, b, c, d};
    const int orders[4][4] = {{0, 1, 2, 3}, {1, 0, 2, 3}, {3, 1, 0, 2}, {2, 3, 1, 0}};
    for (const auto& o : orders)
        CHECK(tet_min_dihedral_deg(p[o[0]], p[o[1]], p[o[2]], p[o[3]]) == Approx(0.0).margin(1e-9));
    // Flat with one point inside the triangle of the others.
    CHECK(tet_min_dihedral_deg(a, Vector3d(3, 0, 0), Vector3d(0, 3, 0), Vector3d(1, 1, 0)) ==
          Approx(0.0).margin(1e-9));
    // A sliver: four nearly coplanar points with good faces.
    const Vector3d s[4] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 1e-3}, {0, -1, 1e-3}};
    CHECK(tet_min_dihedral_deg(s[0], s[1], s[2], s[3]) < 1.0);
    CHECK(tet_skewness(s[0], s[1], s[2], s[3]) > 0.99);
    CHECK(tet_skewness(s[0], s[1], s[2], s[3]) < 1.0);
    // Coincident vertices.
    CHECK(tet_skewness(a, a, b, c) == 1.0);
    CHECK(tet_min_dihedral_deg(a, a, b, c) == 0.0);
}

TEST_CASE("quality measures stay within their ranges on random elements", "[core]") {
    std::mt19937_64 rng(61);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    auto point = [&]() { return Vector3d(u(rng), u(rng), u(rng)); };
    for (int trial = 0; trial < 2000; ++trial) {
        const Vector3d a = point(), b = point(), c = point(), d = point();
        const double ts = triangle_skewness(a, b, c);
        CHECK((ts >= 0.0 && ts <= 1.0));
        const double angle = triangle_min_angle_deg(a, b, c);
        CHECK((angle >= 0.0 && angle <= 60.0 + 1e-9));
        const double es = tet_skewness(a, b, c, d);
        CHECK((es >= 0.0 && es <= 1.0));
        const double dihedral = tet_min_dihedral_deg(a, b, c, d);
        CHECK((dihedral >= 0.0 && dihedral <= regular_dihedral_deg + 1e-9));
        // The six volumes of a tetrahedron's orderings agree up to sign.
        CHECK(tet_signed_volume(a, b, c, d) ==
              Approx(-tet_signed_volume(b, a, c, d)).margin(1e-14));
        CHECK(tet_min_dihedral_deg(d, c, b, a) == Approx(dihedral).margin(1e-9));
    }
}

TEST_CASE("tet_figures: skewness and all six dihedral angles of a tetrahedron", "[core]") {
    // Corner tet: three right angles at the axes, three of acos(1/sqrt(3)).
    const Vector3d o(0, 0, 0), x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
    const double small = std::acos(1.0 / std::sqrt(3.0)) * 180.0 / std::numbers::pi;
    for (const TetFigures& f : {tet_figures(o, x, y, z), tet_figures(o, y, x, z)}) {
        CHECK(f.skewness == Approx(0.5).epsilon(1e-12));
        int right = 0, acute = 0;
        for (const float angle : f.dihedral_deg) {
            if (std::abs(angle - 90.0) < 1e-4) ++right;
            if (std::abs(angle - small) < 1e-4) ++acute;
        }
        CHECK(right == 3);
        CHECK(acute == 3);
        CHECK(f.min_dihedral_deg() == Approx(small).epsilon(1e-6));
        CHECK(f.max_dihedral_deg() == Approx(90.0).epsilon(1e-6));
    }
    // A zero-area face: skewness 1, angles 0 and 180.
    const TetFigures flat = tet_figures(o, o, x, y);
    CHECK(flat.skewness == 1.0);
    CHECK(flat.min_dihedral_deg() == 0.0);
    CHECK(flat.max_dihedral_deg() == 180.0);
    // Random tets: the same figures as the single measures, for either orientation; the
    // six angles of a tet sum to between 360 and 540 degrees.
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    auto point = [&]() { return Vector3d(u(rng), u(rng), u(rng)); };
    for (int trial = 0; trial < 500; ++trial) {
        const Vector3d a = point(), b = point(), c = point(), d = point();
        const TetFigures f = tet_figures(a, b, c, d);
        CHECK(f.skewness == tet_skewness(a, b, c, d));
        CHECK(f.min_dihedral_deg() == static_cast<float>(tet_min_dihedral_deg(a, b, c, d)));
        CHECK(tet_figures(b, a, c, d).min_dihedral_deg() ==
              Approx(f.min_dihedral_deg()).margin(1e-4));
        double sum = 0.0;
        for (const float angle : f.dihedral_deg) sum += angle;
        CHECK((sum > 360.0 - 1e-3 && sum < 540.0 + 1e-3));
    }
}
