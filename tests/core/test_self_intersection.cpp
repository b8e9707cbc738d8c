#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <tbb/global_control.h>
#include <catch2/catch.hpp>

#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/self_intersection.h"
#include "tests/fixtures/phantoms.h"

using namespace frontmesh;
using core::SurfaceNetwork;

namespace {

using Pairs = std::vector<std::pair<std::int32_t, std::int32_t>>;

SurfaceNetwork make_surface(const std::vector<Eigen::Vector3d>& points,
                            const std::vector<std::array<std::int32_t, 3>>& faces) {
    SurfaceNetwork s;
    for (const auto& p : points) s.add_vertex(p);
    for (const auto& f : faces) s.add_face(f[0], f[1], f[2], 1, 0);
    return s;
}

// Appends `src` moved by `shift` as region `region`, vertex ids offset.
void append(SurfaceNetwork& dst, const SurfaceNetwork& src, const Eigen::Vector3d& shift,
            core::Label region) {
    const auto offset = static_cast<std::int32_t>(dst.vertex_count());
    for (std::size_t v = 0; v < src.vertex_count(); ++v)
        dst.add_vertex(src.point(static_cast<std::int32_t>(v)) + shift);
    for (const auto& f : src.faces)
        dst.add_face(f[0] + offset, f[1] + offset, f[2] + offset, region, 0);
}

// O(n^2) reference without a broad phase, for surfaces of proper (non-degenerate) faces.
Pairs brute_force(const SurfaceNetwork& s) {
    Pairs out;
    auto p = [&](std::int32_t v) { return &s.xyz[3 * static_cast<std::size_t>(v)]; };
    for (std::size_t f = 0; f < s.face_count(); ++f)
        for (std::size_t g = f + 1; g < s.face_count(); ++g) {
            const auto& a = s.faces[f];
            const auto& b = s.faces[g];
            std::vector<std::int32_t> shared, a_only, b_only;
            for (auto v : a)
                (std::find(b.begin(), b.end(), v) != b.end() ? shared : a_only).push_back(v);
            for (auto v : b)
                if (std::find(a.begin(), a.end(), v) == a.end()) b_only.push_back(v);
            bool hit = false;
            if (shared.empty()) {
                hit =
                    core::triangles_intersect(p(a[0]), p(a[1]), p(a[2]), p(b[0]), p(b[1]), p(b[2]));
            } else if (shared.size() == 1) {
                hit = core::segment_intersects_triangle(p(a_only[0]), p(a_only[1]), p(b[0]),
                                                        p(b[1]), p(b[2])) ||
                      core::segment_intersects_triangle(p(b_only[0]), p(b_only[1]), p(a[0]),
                                                        p(a[1]), p(a[2]));
            } else if (shared.size() == 2) {
                const double *u = p(shared[0]), *w = p(shared[1]), *x = p(a_only[0]),
                             *y = p(b_only[0]);
                if (core::orient3d(u, w, x, y) == 0)
                    for (auto [i, j] : {std::pair{0, 1}, {1, 2}, {2, 0}}) {
                        const int sx = core::orient2d(u, w, x, i, j);
                        if (sx == 0) continue;
                        hit = core::orient2d(u, w, y, i, j) == sx;
                        break;
                    }
            } else {
                hit = true;
            }
            if (hit) out.emplace_back(static_cast<std::int32_t>(f), static_cast<std::int32_t>(g));
        }
    return out;
}

bool all_proper(const SurfaceNetwork& s) {
    for (const auto& f : s.faces)
        if (core::is_degenerate_triangle(&s.xyz[3 * std::size_t(f[0])],
                                         &s.xyz[3 * std::size_t(f[1])],
                                         &s.xyz[3 * std::size_t(f[2])]))
            return false;
    return true;
}

bool sorted_unique_ordered(const Pairs& pairs) {
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        if (pairs[i].first >= pairs[i].second) return false;
        if (i > 0 && !(pairs[i - 1] < pairs[i])) return false;
    }
    return true;
}

bool incident(const SurfaceNetwork& s, std::int32_t face, std::int32_t vertex) {
    const auto& f = s.faces[static_cast<std::size_t>(face)];
    return f[0] == vertex || f[1] == vertex || f[2] == vertex;
}

// The surface of the cube [0, k]^3 (grid units) as 2 k^2 triangles per side, outward, with the
// quad diagonals alternating; positions origin + spacing * grid, so that sides are exactly
// planar while most coordinate differences are not exact.
SurfaceNetwork grid_cube(int k, double origin, double spacing) {
    SurfaceNetwork s;
    std::map<std::array<int, 3>, std::int32_t> ids;
    auto id = [&](const std::array<int, 3>& g) {
        const auto [it, inserted] = ids.try_emplace(g, 0);
        if (inserted)
            it->second = s.add_vertex(Eigen::Vector3d(
                origin + spacing * g[0], origin + spacing * g[1], origin + spacing * g[2]));
        return it->second;
    };
    for (int axis = 0; axis < 3; ++axis)
        for (int side : {0, k}) {
            const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // e_u x e_v = e_axis
            for (int i = 0; i < k; ++i)
                for (int j = 0; j < k; ++j) {
                    auto corner = [&](int di, int dj) {
                        std::array<int, 3> g{};
                        g[static_cast<std::size_t>(axis)] = side;
                        g[static_cast<std::size_t>(u)] = i + di;
                        g[static_cast<std::size_t>(v)] = j + dj;
                        return id(g);
                    };
                    const std::int32_t c00 = corner(0, 0), c10 = corner(1, 0), c11 = corner(1, 1),
                                       c01 = corner(0, 1);
                    std::array<std::array<std::int32_t, 3>, 2> tris =
                        (i + j) % 2 == 0
                            ? std::array<std::array<std::int32_t, 3>, 2>{{{c00, c10, c11},
                                                                          {c00, c11, c01}}}
                            : std::array<std::array<std::int32_t, 3>, 2>{
                                  {{c00, c10, c01}, {c10, c11, c01}}};
                    for (auto t : tris) {
                        if (side == 0) std::swap(t[1], t[2]);  // outward is -e_axis
                        s.add_face(t[0], t[1], t[2], 1, 0);
                    }
                }
        }
    return s;
}

}  // namespace

TEST_CASE("a finely triangulated cube with exactly coplanar neighbours", "[core]") {
    SurfaceNetwork s = grid_cube(8, 12.7, 0.3);
    const auto checks = core::check_region_boundaries(s);
    REQUIRE(checks.size() == 1);
    REQUIRE(checks[0].is_closed());
    REQUIRE(checks[0].is_oriented());
    CHECK(core::self_intersections(s).empty());
    CHECK(brute_force(s).empty());

    // Slide a vertex of the top side within its plane past its neighbours: faces fold flat
    // onto each other and overlap.
    std::int32_t moved = -1;
    for (std::size_t v = 0; v < s.vertex_count(); ++v) {
        const auto p = s.point(static_cast<std::int32_t>(v));
        if (p.z() == 12.7 + 0.3 * 8 && p.x() == 12.7 + 0.3 * 4 && p.y() == 12.7 + 0.3 * 4)
            moved = static_cast<std::int32_t>(v);
    }
    REQUIRE(moved >= 0);
    s.point(moved).x() += 0.45;
    const Pairs pairs = core::self_intersections(s);
    REQUIRE_FALSE(pairs.empty());
    CHECK(pairs == brute_force(s));
    for (const auto& [f, g] : pairs) CHECK((incident(s, f, moved) || incident(s, g, moved)));
}

TEST_CASE("closed surfaces have no self-intersections", "[core]") {
    CHECK(core::self_intersections(fixtures::octahedron(2.0)).empty());
    for (int n : {3, 8, 40}) CHECK(core::self_intersections(fixtures::uv_sphere(1.5, n)).empty());
    // Far from the origin the coordinates are large and the neighbours nearly coplanar.
    SurfaceNetwork far;
    append(far, fixtures::uv_sphere(1e-3, 30), {1e4, -2e4, 3e4}, 1);
    CHECK(core::self_intersections(far).empty());
}

TEST_CASE("a sphere vertex pushed through the opposite side intersects", "[core]") {
    SurfaceNetwork s = fixtures::uv_sphere(1.0, 16);
    // The equator vertex at (1, 0, 0): ring 8 of 16, segment 0 of 32.
    const std::int32_t v = 1 + 7 * 32;
    REQUIRE(std::abs(s.point(v).x() - 1.0) < 1e-12);

    s.point(v) = Eigen::Vector3d(0.9, 0.0, 0.0);  // a small dent stays clean
    CHECK(core::self_intersections(s).empty());

    s.point(v) = Eigen::Vector3d(-1.3, 0.05, 0.02);
    const Pairs pairs = core::self_intersections(s);
    REQUIRE_FALSE(pairs.empty());
    CHECK(sorted_unique_ordered(pairs));
    for (const auto& [f, g] : pairs) CHECK((incident(s, f, v) || incident(s, g, v)));
    CHECK(pairs == brute_force(s));
}

TEST_CASE("two overlapping spheres in one network intersect each other", "[core]") {
    SurfaceNetwork s = fixtures::uv_sphere(1.0, 12);
    const auto n_first = static_cast<std::int32_t>(s.face_count());
    append(s, fixtures::uv_sphere(1.0, 12), {0.8, 0.1, 0.05}, 2);
    const Pairs pairs = core::self_intersections(s);
    REQUIRE_FALSE(pairs.empty());
    CHECK(sorted_unique_ordered(pairs));
    for (const auto& [f, g] : pairs) CHECK((f < n_first && g >= n_first));
    CHECK(pairs == brute_force(s));

    SurfaceNetwork apart = fixtures::uv_sphere(1.0, 12);
    append(apart, fixtures::uv_sphere(1.0, 12), {2.5, 0.0, 0.0}, 2);
    CHECK(core::self_intersections(apart).empty());
}

TEST_CASE("touching at a point counts unless the point is a shared vertex", "[core]") {
    // Two octahedra touching at (1, 0, 0): vertex 0 of the first, vertex 1 of the second.
    SurfaceNetwork s = fixtures::octahedron(1.0);
    append(s, fixtures::octahedron(1.0), {2.0, 0.0, 0.0}, 2);
    const std::int32_t a = 0, b = 6 + 1;
    REQUIRE(s.point(a) == s.point(b));
    std::set<std::pair<std::int32_t, std::int32_t>> expected;
    for (std::int32_t f = 0; f < 8; ++f)
        for (std::int32_t g = 8; g < 16; ++g)
            if (incident(s, f, a) && incident(s, g, b)) expected.emplace(f, g);
    const Pairs pairs = core::self_intersections(s);
    CHECK(Pairs(expected.begin(), expected.end()) == pairs);

    // Welded: the second octahedron uses vertex 0 itself; they meet only there.
    for (auto& f : s.faces)
        for (auto& v : f)
            if (v == b) v = a;
    CHECK(core::self_intersections(s).empty());
}

TEST_CASE("faces sharing an edge count only when folded onto each other", "[core]") {
    const std::vector<std::array<std::int32_t, 3>> faces = {{0, 1, 2}, {1, 0, 3}};
    const Eigen::Vector3d p0(0, 0, 0), p1(1, 0, 0), p2(0.3, 1, 0);
    // Folded flat: the third vertices on the same side of the edge, in the same plane.
    CHECK(core::self_intersections(make_surface({p0, p1, p2, {0.6, 0.4, 0}}, faces)) ==
          Pairs{{0, 1}});
    CHECK(core::self_intersections(make_surface({p0, p1, p2, {5.0, 0.1, 0}}, faces)) ==
          Pairs{{0, 1}});
    // Flat but on opposite sides, a sharp crease, and a right angle: only the edge is common.
    CHECK(core::self_intersections(make_surface({p0, p1, p2, {0.6, -0.4, 0}}, faces)).empty());
    CHECK(core::self_intersections(make_surface({p0, p1, p2, {0.3, 1, 1e-12}}, faces)).empty());
    CHECK(core::self_intersections(make_surface({p0, p1, p2, {0.5, 0, 1}}, faces)).empty());
    // Folded flat in a tilted plane with non-representable coordinates.
    const Eigen::Vector3d q0(0.1, 0.2, 0.3), q1(1.1, 0.7, -0.3),
        q2 = q0 + 0.3 * (q1 - q0) + Eigen::Vector3d(0, 0.5, 0.5);
    const Eigen::Vector3d q3 = q0 + 0.6 * (q1 - q0) + Eigen::Vector3d(0, 0.25, 0.25);
    const SurfaceNetwork tilted = make_surface({q0, q1, q2, q3}, faces);
    CHECK(core::self_intersections(tilted) == brute_force(tilted));
    // A duplicated face overlaps entirely.
    CHECK(core::self_intersections(make_surface({p0, p1, p2}, {{0, 1, 2}, {2, 1, 0}})) ==
          Pairs{{0, 1}});
}

TEST_CASE("faces sharing one vertex count when they meet anywhere else", "[core]") {
    const Eigen::Vector3d v(0, 0, 0), a1(2, 0, 0), a2(0, 2, 0);
    const std::vector<std::array<std::int32_t, 3>> faces = {{0, 1, 2}, {0, 3, 4}};
    auto pairs_for = [&](const Eigen::Vector3d& b1, const Eigen::Vector3d& b2) {
        return core::self_intersections(make_surface({v, a1, a2, b1, b2}, faces));
    };
    // Meeting only at the shared vertex: another plane, or the opposite sector of the plane.
    CHECK(pairs_for({0, 0, 1}, {-1, -1, 1}).empty());
    CHECK(pairs_for({-1, 0, 0}, {0, -1, 0}).empty());
    CHECK(pairs_for({-1, 0.5, 0}, {-1, 2, 0}).empty());
    // The opposite edge of the second face crosses the first.
    CHECK(pairs_for({0.5, 0.5, 1}, {0.5, 0.5, -1}) == Pairs{{0, 1}});
    // Coplanar sectors overlapping.
    CHECK(pairs_for({1, 1, 0}, {3, -1, 0}) == Pairs{{0, 1}});
    // Coplanar, sharing only a piece of the edge ray from v (sectors on either side).
    CHECK(pairs_for({1, 0, 0}, {1, -1, 0}) == Pairs{{0, 1}});
    // In another plane, but one edge runs along the first face's edge from v.
    CHECK(pairs_for({3, 0, 0}, {1, 0, 1}) == Pairs{{0, 1}});
    // An edge from v entering the first face's interior.
    CHECK(pairs_for({1, 0.5, 0}, {1, 0.5, 1}) == Pairs{{0, 1}});
    // A degenerate second face: a segment through v, entering the first face or not.
    CHECK(pairs_for({-1, -1, 0}, {1, 1, 0}) == Pairs{{0, 1}});
    CHECK(pairs_for({-1, -1, 0}, {-2, -2, 0}).empty());
    CHECK(pairs_for({-1, 1, 0}, {1, -1, 0}).empty());
}

TEST_CASE("self_intersections agrees with brute force on tangled random surfaces", "[core]") {
    std::mt19937_64 rng(51);
    std::normal_distribution<double> noise(0.0, 0.12);
    for (int trial = 0; trial < 4; ++trial) {
        SurfaceNetwork s = fixtures::uv_sphere(1.0, 9);
        append(s, fixtures::uv_sphere(0.6, 7), {0.5, 0.2, 0.0}, 2);
        // A large triangle cutting through both, among small faces.
        const auto base = static_cast<std::int32_t>(s.vertex_count());
        s.add_vertex({-3, -3, 0.1});
        s.add_vertex({4, -2, -0.2});
        s.add_vertex({0, 4, 0.3});
        s.add_face(base, base + 1, base + 2, 3, 0);
        for (std::size_t v = 0; v < s.vertex_count(); ++v)
            s.point(static_cast<std::int32_t>(v)) +=
                Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
        REQUIRE(all_proper(s));
        const Pairs pairs = core::self_intersections(s);
        INFO("trial " << trial);
        CHECK(pairs.size() > 50);
        CHECK(sorted_unique_ordered(pairs));
        CHECK(pairs == brute_force(s));
        // The limit keeps the first pairs of the sorted list.
        for (std::size_t limit : {std::size_t(1), std::size_t(7), pairs.size() + 3}) {
            const Pairs head = core::self_intersections(s, limit);
            CHECK(head == Pairs(pairs.begin(), pairs.begin() + std::min(limit, pairs.size())));
        }
    }
}

TEST_CASE("self_intersections gives the same pairs for any thread count", "[core]") {
    std::mt19937_64 rng(52);
    std::normal_distribution<double> noise(0.0, 0.02);
    SurfaceNetwork s = fixtures::uv_sphere(1.0, 60);
    append(s, fixtures::uv_sphere(0.8, 50), {0.3, 0.1, 0.0}, 2);
    for (std::size_t v = 0; v < s.vertex_count(); ++v)
        s.point(static_cast<std::int32_t>(v)) +=
            Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    Pairs serial;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        serial = core::self_intersections(s);
    }
    REQUIRE(serial.size() > 100);
    CHECK(sorted_unique_ordered(serial));
    for (std::size_t threads : {2, 4}) {
        tbb::global_control many(tbb::global_control::max_allowed_parallelism, threads);
        CHECK(core::self_intersections(s) == serial);
    }
}

TEST_CASE("self_intersections rejects invalid surfaces", "[core]") {
    SurfaceNetwork s = fixtures::octahedron(1.0);
    s.faces[3][1] = 99;
    CHECK_THROWS_AS(core::self_intersections(s), core::InputError);
    SurfaceNetwork t = fixtures::octahedron(1.0);
    t.xyz[4] = std::nan("");
    CHECK_THROWS_AS(core::self_intersections(t), core::InputError);
    CHECK(core::self_intersections(SurfaceNetwork{}).empty());
}
