// Quadratic tets (output.order 2, volume/quadratic.h): one mid node per edge, interior ones
// at midpoints, surface ones on the background, and no element with a non-positive Jacobian.

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <vector>

#include <catch2/catch.hpp>

#include "io/split_interfaces.h"
#include "pipeline/core/quadratic_nodes.h"
#include "pipeline/core/quality.h"
#include "pipeline/core/stage_context.h"
#include "tests/fixtures/phantoms.h"
#include "volume/quadratic.h"
#include "volume/tetra.h"

using namespace frontmesh;
using V3 = Eigen::Vector3d;

namespace {

std::array<V3, 10> straight_tet(const V3& a, const V3& b, const V3& c, const V3& d) {
    std::array<V3, 10> x{a, b, c, d};
    for (int k = 0; k < 6; ++k)
        x[static_cast<std::size_t>(4 + k)] =
            0.5 * (x[static_cast<std::size_t>(core::kTetEdge[k][0])] +
                   x[static_cast<std::size_t>(core::kTetEdge[k][1])]);
    return x;
}

// det J of the quadratic map at barycentric (l1, l2, l3), by the standard tet10 shape
// functions (independent of the Bezier form the bound uses).
double jacobian_at(const std::array<V3, 10>& x, double l1, double l2, double l3) {
    const double l[4] = {1.0 - l1 - l2 - l3, l1, l2, l3};
    // dN/dl_i of N_corner_i = l_i (2 l_i - 1) and N_edge_ij = 4 l_i l_j; dxi_k = dl_k - dl_0.
    V3 dl[4];
    for (int i = 0; i < 4; ++i) dl[i] = (4.0 * l[i] - 1.0) * x[static_cast<std::size_t>(i)];
    for (int k = 0; k < 6; ++k) {
        const int i = core::kTetEdge[k][0], j = core::kTetEdge[k][1];
        dl[i] += 4.0 * l[j] * x[static_cast<std::size_t>(4 + k)];
        dl[j] += 4.0 * l[i] * x[static_cast<std::size_t>(4 + k)];
    }
    const V3 d1 = dl[1] - dl[0], d2 = dl[2] - dl[0], d3 = dl[3] - dl[0];
    return d1.dot(d2.cross(d3));
}

core::TetMesh sphere_mesh(double radius, int segments) {
    core::StageContext ctx;
    return volume::tetra(fixtures::uv_sphere(radius, segments), volume::TetraParams{}, ctx);
}

double min_scaled_jacobian(const core::TetMesh& q) {
    double lowest = 1e300;
    for (std::size_t t = 0; t < q.tet_count(); ++t) {
        std::array<V3, 10> x;
        for (int k = 0; k < 4; ++k) x[static_cast<std::size_t>(k)] = q.point(q.tets[t][k]);
        for (int k = 0; k < 6; ++k) x[static_cast<std::size_t>(4 + k)] = q.point(q.tet_mid[t][k]);
        const double straight = (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0]));
        lowest = std::min(lowest, volume::min_bezier_jacobian(x) / straight);
    }
    return lowest;
}

/// Every tet edge has one mid node, shared by all tets and faces on it.
void check_shared_numbering(const core::TetMesh& linear, const core::TetMesh& q) {
    REQUIRE(q.tet_mid.size() == linear.tet_count());
    REQUIRE(q.face_mid.size() == linear.face_count());
    std::map<std::pair<std::int32_t, std::int32_t>, std::int32_t> mid_of;
    bool consistent = true;
    for (std::size_t t = 0; t < q.tet_count(); ++t)
        for (int k = 0; k < 6; ++k) {
            const std::int32_t a = q.tets[t][core::kTetEdge[k][0]],
                               b = q.tets[t][core::kTetEdge[k][1]];
            const auto [it, added] = mid_of.emplace(std::minmax(a, b), q.tet_mid[t][k]);
            consistent = consistent && it->second == q.tet_mid[t][k];
        }
    CHECK(consistent);
    CHECK(q.node_count() == linear.node_count() + mid_of.size());
    std::set<std::int32_t> mids;
    for (const auto& [edge, m] : mid_of) mids.insert(m);
    CHECK(mids.size() == mid_of.size());
    CHECK(*mids.begin() == static_cast<std::int32_t>(linear.node_count()));  // after the corners
    bool faces_match = true;
    for (std::size_t f = 0; f < q.face_count(); ++f)
        for (int k = 0; k < 3; ++k) {
            const auto e =
                std::minmax(q.faces[f][core::kTriEdge[k][0]], q.faces[f][core::kTriEdge[k][1]]);
            faces_match = faces_match && mid_of.at(e) == q.face_mid[f][k];
        }
    CHECK(faces_match);
}

}  // namespace

TEST_CASE("the Bezier bound of a quadratic tet's Jacobian", "[volume][quadratic]") {
    const V3 a(0, 0, 0), b(2, 0, 0), c(0.3, 1.8, 0), d(0.5, 0.6, 1.5);
    const auto x = straight_tet(a, b, c, d);
    const double straight = (b - a).dot((c - a).cross(d - a));
    CHECK(straight > 0);
    CHECK(volume::min_bezier_jacobian(x) == Approx(straight).epsilon(1e-12));
    CHECK(straight == Approx(6.0 * core::tet_signed_volume(a, b, c, d)).epsilon(1e-12));

    // Random curved tets: the bound never exceeds det J at sample points, and it is exact
    // at the corners' values (det J there is a coefficient).
    std::mt19937 rng(20261204);
    std::uniform_real_distribution<double> shift(-0.35, 0.35), u(0.0, 1.0);
    int below = 0, negative_bounds = 0;
    for (int trial = 0; trial < 200; ++trial) {
        auto y = x;
        for (int k = 4; k < 10; ++k)
            y[static_cast<std::size_t>(k)] += V3(shift(rng), shift(rng), shift(rng));
        const double bound = volume::min_bezier_jacobian(y);
        negative_bounds += bound <= 0 ? 1 : 0;
        double lowest = 1e300;
        for (int s = 0; s < 400; ++s) {
            const double l1 = u(rng), l2 = u(rng), l3 = u(rng);
            if (l1 + l2 + l3 > 1.0) continue;  // outside the reference tet
            lowest = std::min(lowest, jacobian_at(y, l1, l2, l3));
        }
        constexpr std::array<std::array<double, 3>, 4> kCorners{
            {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
        for (const auto& [l1, l2, l3] : kCorners)
            lowest = std::min(lowest, jacobian_at(y, l1, l2, l3));
        below += bound <= lowest + 1e-9 * straight ? 1 : 0;
    }
    CHECK(below == 200);
    CHECK(negative_bounds > 0);  // the shifts are large enough to invert some
    // A mid node pulled through the opposite face inverts the element: the bound says so.
    auto inverted = x;
    inverted[7] = d + 1.2 * (a - d);  // mid node of edge 0-3 beyond node 0
    CHECK(volume::min_bezier_jacobian(inverted) < 0);
}

TEST_CASE("quadratic tets of a sphere: curved surface, straight inside, all valid",
          "[volume][quadratic]") {
    const double r = 10.0;
    const core::TetMesh mesh = sphere_mesh(r, 12);
    const core::SurfaceNetwork background = fixtures::uv_sphere(r, 120);
    volume::QuadraticStats stats;
    const core::TetMesh q = volume::elevate_to_quadratic(mesh, &background, &stats);
    check_shared_numbering(mesh, q);
    CHECK(q.is_quadratic());
    CHECK(stats.edges == q.node_count() - mesh.node_count());
    CHECK(std::equal(mesh.xyz.begin(), mesh.xyz.end(), q.xyz.begin()));  // corners untouched
    CHECK(min_scaled_jacobian(q) >= volume::kMinScaledJacobian);
    CHECK(stats.min_scaled_jacobian >= volume::kMinScaledJacobian);

    // Mid nodes: interior edges at their midpoints exactly; surface edges nearer to the
    // sphere than the chord's midpoint (the sagitta of a 12-segment sphere is ~0.3 mm).
    std::set<std::pair<std::int32_t, std::int32_t>> surface_edges;
    for (const auto& f : mesh.faces)
        for (int k = 0; k < 3; ++k) surface_edges.insert(std::minmax(f[k], f[(k + 1) % 3]));
    std::size_t interior_exact = 0, interior = 0, nearer = 0, surface = 0;
    double worst_gap = 0;
    std::set<std::int32_t> seen;
    for (std::size_t t = 0; t < q.tet_count(); ++t)
        for (int k = 0; k < 6; ++k) {
            const std::int32_t m = q.tet_mid[t][k];
            if (!seen.insert(m).second) continue;
            const std::int32_t a = q.tets[t][core::kTetEdge[k][0]],
                               b = q.tets[t][core::kTetEdge[k][1]];
            const V3 mid = 0.5 * (q.point(a) + q.point(b));
            if (surface_edges.count(std::minmax(a, b))) {
                ++surface;
                const double gap = std::abs(q.point(m).norm() - r);
                worst_gap = std::max(worst_gap, gap);
                nearer += gap < std::abs(mid.norm() - r) ? 1 : 0;
            } else {
                ++interior;
                interior_exact += q.point(m) == mid ? 1 : 0;
            }
        }
    INFO("surface edges " << surface << ", nearer the sphere " << nearer << ", curved "
                          << stats.curved << ", taken back " << stats.straightened
                          << ", worst |r - R| " << worst_gap);
    CHECK(interior_exact == interior);
    CHECK(surface == stats.surface_edges);
    CHECK(nearer + stats.straightened >= surface);
    CHECK(nearer > surface * 9 / 10);
    CHECK(worst_gap < 0.35);
}

TEST_CASE("a curved mid node that would invert a flat tet falls back to the midpoint",
          "[volume][quadratic]") {
    // One flat tet (height 0.05 over a base of edge ~1) whose every face is boundary, and a
    // background through its corners that bulges between them, z = 0.6 d^2 (d: distance to
    // the nearest base corner, 0.15 at the base edges' midpoints): projected mid nodes of the
    // base edges would rise above the apex and fold the element.
    core::TetMesh mesh;
    mesh.add_node(V3(0, 0, 0));
    mesh.add_node(V3(1, 0, 0));
    mesh.add_node(V3(0.5, 0.9, 0));
    mesh.add_node(V3(0.5, 0.3, 0.05));
    mesh.add_tet(0, 1, 2, 3, 1);
    REQUIRE(core::tet_signed_volume(mesh.point(0), mesh.point(1), mesh.point(2), mesh.point(3)) >
            0);
    core::derive_boundary_faces(mesh);
    mesh.surface_vertices = 4;
    core::SurfaceNetwork plane;
    const int n = 60;  // grid over [-0.5, 1.5]^2, step 1/30
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const double x = -0.5 + 2.0 * i / n, y = -0.5 + 2.0 * j / n;
            double d2 = 1e300;
            for (int k = 0; k < 3; ++k)
                d2 = std::min(d2, (V3(x, y, 0) - mesh.point(k)).squaredNorm());
            plane.xyz.insert(plane.xyz.end(), {x, y, 0.6 * d2});
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
            plane.add_face(a, b, d, 1, 0);
            plane.add_face(a, d, c, 1, 0);
        }
    volume::QuadraticStats stats;
    const core::TetMesh q = volume::elevate_to_quadratic(mesh, &plane, &stats);
    INFO("curved " << stats.curved << ", taken back " << stats.straightened);
    CHECK(stats.straightened > 0);
    CHECK(min_scaled_jacobian(q) >= volume::kMinScaledJacobian);
    // Without the check the same placement inverts it.
    std::array<V3, 10> raw;
    for (int k = 0; k < 4; ++k) raw[static_cast<std::size_t>(k)] = mesh.point(k);
    for (int k = 0; k < 6; ++k) {
        const V3 m = 0.5 * (mesh.point(core::kTetEdge[k][0]) + mesh.point(core::kTetEdge[k][1]));
        raw[static_cast<std::size_t>(4 + k)] = V3(m.x(), m.y(), 0.15);
    }
    CHECK(volume::min_bezier_jacobian(raw) < 0);
}

TEST_CASE("quadratic tets of a split interface: each side its own mid nodes, same places",
          "[volume][quadratic][split]") {
    const core::TetMesh mesh = fixtures::cube_tet_mesh(4, 1.0, true);
    io::SplitInterfaces spec;
    spec.all = true;
    const core::TetMesh split = io::split_interfaces(mesh, spec);
    // A background a little above the interface plane z = 2: curved mid nodes there.
    core::SurfaceNetwork bump;
    bump.xyz = {-1, -1, 2.05, 5, -1, 2.05, 5, 5, 2.05, -1, 5, 2.05};
    bump.add_face(0, 1, 2, 1, 2);
    bump.add_face(0, 2, 3, 1, 2);
    volume::QuadraticStats stats;
    const core::TetMesh q = volume::elevate_to_quadratic(split, &bump, &stats);
    check_shared_numbering(split, q);
    REQUIRE(q.twin.size() == q.node_count());
    CHECK(stats.curved > 0);
    CHECK(min_scaled_jacobian(q) >= volume::kMinScaledJacobian);
    // Each mid node's twin sits at the same place; the two sides of the interface have
    // distinct mid nodes.
    std::size_t copies = 0;
    bool same_place = true;
    for (std::size_t v = split.node_count(); v < q.node_count(); ++v) {
        const std::int32_t w = q.twin[v];
        REQUIRE(w >= static_cast<std::int32_t>(split.node_count()));
        if (w == static_cast<std::int32_t>(v)) continue;
        ++copies;
        same_place = same_place && q.point(static_cast<std::int32_t>(v)) == q.point(w);
    }
    CHECK(copies > 0);
    CHECK(same_place);
    std::set<std::int32_t> lower, upper;
    for (std::size_t t = 0; t < q.tet_count(); ++t)
        for (const std::int32_t m : q.tet_mid[t]) (q.region[t] == 1 ? lower : upper).insert(m);
    std::vector<std::int32_t> common;
    std::set_intersection(lower.begin(), lower.end(), upper.begin(), upper.end(),
                          std::back_inserter(common));
    CHECK(common.empty());
}
