#include "surface/repair.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>

#include "pipeline/core/error.h"
#include "pipeline/core/surface_network.h"
#include "tests/fixtures/phantoms.h"

using namespace frontmesh;
using core::Label;
using core::SurfaceNetwork;

namespace {

SurfaceNetwork translated(SurfaceNetwork s, const Eigen::Vector3d& d) {
    for (std::size_t v = 0; v < s.vertex_count(); ++v) s.point(static_cast<std::int32_t>(v)) += d;
    return s;
}

SurfaceNetwork labelled(SurfaceNetwork s, Label in, Label out) {
    std::fill(s.region_in.begin(), s.region_in.end(), in);
    std::fill(s.region_out.begin(), s.region_out.end(), out);
    return s;
}

SurfaceNetwork reversed(SurfaceNetwork s) {
    for (auto& t : s.faces) std::swap(t[1], t[2]);
    return s;
}

/// Appends `src` to `dst` with its own vertices.
void append(SurfaceNetwork& dst, const SurfaceNetwork& src) {
    const auto offset = static_cast<std::int32_t>(dst.vertex_count());
    dst.xyz.insert(dst.xyz.end(), src.xyz.begin(), src.xyz.end());
    for (std::size_t f = 0; f < src.face_count(); ++f) {
        const auto& t = src.faces[f];
        dst.add_face(t[0] + offset, t[1] + offset, t[2] + offset, src.region_in[f],
                     src.region_out[f]);
    }
}

/// Removes the faces for which `drop(f)` holds (vertices stay, unused).
template <class Drop>
SurfaceNetwork without_faces(const SurfaceNetwork& s, Drop drop) {
    SurfaceNetwork r;
    r.xyz = s.xyz;
    for (std::size_t f = 0; f < s.face_count(); ++f)
        if (!drop(f)) {
            const auto& t = s.faces[f];
            r.add_face(t[0], t[1], t[2], s.region_in[f], s.region_out[f]);
        }
    return r;
}

double area(const SurfaceNetwork& s) {
    double a = 0.0;
    for (const auto& t : s.faces)
        a += 0.5 * (s.point(t[1]) - s.point(t[0])).cross(s.point(t[2]) - s.point(t[0])).norm();
    return a;
}

double counter(const core::StageContext& ctx, const std::string& name) {
    const auto it = ctx.counters().find(name);
    INFO("counter " << name);
    REQUIRE(it != ctx.counters().end());
    return it->second;
}

bool has_warning(const core::StageContext& ctx, const std::string& part) {
    return std::any_of(ctx.warnings().begin(), ctx.warnings().end(),
                       [&](const std::string& w) { return w.find(part) != std::string::npos; });
}

void require_closed_and_oriented(const SurfaceNetwork& s) {
    const auto checks = core::check_region_boundaries(s);
    REQUIRE(!checks.empty());
    for (const auto& c : checks) {
        INFO("region " << c.region);
        CHECK(c.is_closed());
        CHECK(c.misoriented_edges == 0);
        CHECK(c.volume > 0.0);
        CHECK(c.nonmanifold_edges == 0);
    }
}

/// `s` as region 2 inside a sphere of region 1 (radius 30 mm): its contacts lie inside the
/// domain.
SurfaceNetwork inside_sphere(const SurfaceNetwork& s) {
    SurfaceNetwork nested = fixtures::uv_sphere(30.0, 16);
    append(nested, labelled(s, 2, 1));
    return nested;
}

/// Every region closed and oriented, with `edges` non-manifold edges in all (2^q faces).
void require_closed_and_oriented_but_edges(const SurfaceNetwork& s, std::size_t edges) {
    const auto checks = core::check_region_boundaries(s);
    std::size_t found = 0;
    for (const auto& c : checks) {
        INFO("region " << c.region);
        CHECK(c.is_closed());
        CHECK(c.is_oriented());
        found += c.nonmanifold_edges;
    }
    CHECK(found == edges);
}

/// Number of (vertex, region) pairs where the region's faces around the vertex form more than
/// one fan (faces linked through the edges at the vertex).
std::size_t pinch_vertices(const SurfaceNetwork& s) {
    std::size_t pinches = 0;
    for (Label region : core::region_labels(s)) {
        std::map<std::int32_t, std::vector<std::int32_t>> around;
        for (std::size_t f = 0; f < s.face_count(); ++f)
            if (s.region_in[f] == region || s.region_out[f] == region)
                for (std::int32_t v : s.faces[f]) around[v].push_back(static_cast<std::int32_t>(f));
        for (const auto& [v, faces] : around) {
            std::vector<std::size_t> fan(faces.size());
            std::iota(fan.begin(), fan.end(), 0);
            auto root = [&](std::size_t x) {
                while (fan[x] != x) x = fan[x];
                return x;
            };
            for (std::size_t a = 0; a < faces.size(); ++a)
                for (std::size_t b = a + 1; b < faces.size(); ++b) {
                    int shared = 0;
                    for (std::int32_t x : s.faces[static_cast<std::size_t>(faces[a])])
                        for (std::int32_t y : s.faces[static_cast<std::size_t>(faces[b])])
                            shared += x == y;
                    if (shared >= 2) fan[root(b)] = root(a);
                }
            std::size_t fans = 0;
            for (std::size_t a = 0; a < faces.size(); ++a) fans += root(a) == a;
            pinches += fans > 1;
        }
    }
    return pinches;
}

// uv_sphere(r, n): vertex 0 is the north pole, ring i (1..n-1) vertex j is 1 + (i-1) 2n + j.
std::int32_t ring_vertex(int n, int i, int j) { return 1 + (i - 1) * 2 * n + j; }

}  // namespace

TEST_CASE("repair leaves a clean sphere unchanged", "[surface]") {
    const SurfaceNetwork s = fixtures::uv_sphere(10.0, 16);
    core::StageContext ctx;
    const SurfaceNetwork out = surface::repair(s, {}, ctx);
    CHECK(out.xyz == s.xyz);
    CHECK(out.faces == s.faces);
    CHECK(out.region_in == s.region_in);
    CHECK(out.region_out == s.region_out);
    for (const char* name :
         {"repair.merged_points", "repair.duplicate_faces", "repair.flipped_faces",
          "repair.filled_holes", "repair.removed_components", "repair.split_vertices",
          "repair.self_intersecting_pairs"})
        CHECK(counter(ctx, name) == 0);
    CHECK(ctx.warnings().empty());
    require_closed_and_oriented(out);
}

TEST_CASE("repair flips misoriented faces back", "[surface]") {
    const SurfaceNetwork s = fixtures::uv_sphere(10.0, 16);
    SurfaceNetwork damaged = s;
    std::size_t flipped = 0;
    SECTION("random 10 %") {
        std::mt19937 rng(20240611);
        std::bernoulli_distribution coin(0.1);
        for (auto& t : damaged.faces)
            if (coin(rng)) {
                std::swap(t[1], t[2]);
                ++flipped;
            }
        REQUIRE(flipped > 0);
    }
    SECTION("inside out") {
        damaged = reversed(s);
        flipped = s.face_count();
    }
    core::StageContext ctx;
    const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
    CHECK(out.faces == s.faces);
    CHECK(counter(ctx, "repair.flipped_faces") == static_cast<double>(flipped));
    CHECK(counter(ctx, "repair.orientation_conflicts") == 0);
    require_closed_and_oriented(out);
    CHECK(core::enclosed_volume(out, 1) == Approx(core::enclosed_volume(s, 1)));
}

TEST_CASE("repair merges duplicate points and drops duplicate faces", "[surface]") {
    const SurfaceNetwork s = fixtures::uv_sphere(10.0, 16);
    SurfaceNetwork damaged = s;
    // Ten vertices copied with new ids, half exactly and half 1e-8 mm away (within the default
    // 1e-6 mm tolerance); every second face using one switches to its copy.
    for (int k = 0; k < 10; ++k) {
        const std::int32_t v = 20 + 37 * k;
        Eigen::Vector3d p = s.point(v);
        if (k % 2 == 1) p.x() += 1e-8;
        const std::int32_t copy = damaged.add_vertex(p);
        int use = 0;
        for (auto& t : damaged.faces)
            for (auto& x : t)
                if (x == v && use++ % 2 == 0) x = copy;
    }
    // Twenty faces again, half of them with their vertex cycle rotated.
    for (int k = 0; k < 20; ++k) {
        const auto f = static_cast<std::size_t>(5 + 41 * k);
        const auto t = damaged.faces[f];
        if (k % 2 == 0)
            damaged.add_face(t[0], t[1], t[2], 1, 0);
        else
            damaged.add_face(t[1], t[2], t[0], 1, 0);
    }
    core::StageContext ctx;
    const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
    CHECK(counter(ctx, "repair.merged_points") == 10);
    CHECK(counter(ctx, "repair.duplicate_faces") == 20);
    CHECK(counter(ctx, "repair.cancelled_faces") == 0);
    // Copies merge into the lower (original) ids and duplicates after the originals go.
    CHECK(out.xyz == s.xyz);
    CHECK(out.faces == s.faces);
    require_closed_and_oriented(out);
}

TEST_CASE("repair cancels a face against its opposite copy", "[surface]") {
    // A zero-thickness fin on edge (a, b): a face and its reversed copy between the same
    // regions. Kept, either one would leave three faces on (a, b) and an open fin.
    const SurfaceNetwork s = fixtures::uv_sphere(10.0, 16);
    SurfaceNetwork damaged = s;
    const auto t = s.faces[100];
    const std::int32_t p = damaged.add_vertex(2.0 * s.point(t[0]));
    damaged.add_face(t[0], t[1], p, 1, 0);
    damaged.add_face(t[0], p, t[1], 1, 0);
    core::StageContext ctx;
    const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
    CHECK(counter(ctx, "repair.cancelled_faces") == 2);
    CHECK(counter(ctx, "repair.unused_points") == 1);
    CHECK(out.xyz == s.xyz);
    CHECK(out.faces == s.faces);
}

TEST_CASE("repair merges points only within merge_tolerance_mm", "[surface]") {
    const SurfaceNetwork s = fixtures::uv_sphere(10.0, 16);
    SurfaceNetwork damaged = s;
    const std::int32_t v = ring_vertex(16, 5, 7);
    const std::int32_t copy = damaged.add_vertex(s.point(v) + Eigen::Vector3d(1e-3, 0, 0));
    int use = 0;
    for (auto& t : damaged.faces)
        for (auto& x : t)
            if (x == v && use++ < 3) x = copy;
    REQUIRE(use == 6);
    surface::RepairParams params;
    SECTION("within: merged") {
        params.merge_tolerance_mm = 1e-2;
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(damaged, params, ctx);
        CHECK(counter(ctx, "repair.merged_points") == 1);
        CHECK(counter(ctx, "repair.filled_holes") == 0);
        CHECK(out.faces == s.faces);
    }
    SECTION("beyond: a crack, closed as a hole") {
        params.merge_tolerance_mm = 1e-4;
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(damaged, params, ctx);
        CHECK(counter(ctx, "repair.merged_points") == 0);
        CHECK(counter(ctx, "repair.filled_holes") == 1);
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 1) == Approx(core::enclosed_volume(s, 1)).epsilon(1e-6));
    }
}

TEST_CASE("repair drops degenerate faces", "[surface]") {
    SECTION("a face with a repeated vertex") {
        const SurfaceNetwork s = fixtures::uv_sphere(10.0, 16);
        SurfaceNetwork damaged = s;
        damaged.add_face(40, 40, 41, 1, 0);
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(counter(ctx, "repair.collapsed_faces") == 1);
        CHECK(out.faces == s.faces);
    }
    SECTION("a zero-area sliver closing a T-junction") {
        // Octahedron with edge (0, 2) split at its midpoint m on one side only; the sliver
        // (0, 2, m) closes the T-junction. (1,0,0), (0,1,0) and (0.5,0.5,0) are exactly
        // collinear in floating point.
        const SurfaceNetwork o = fixtures::octahedron(1.0);
        SurfaceNetwork damaged = without_faces(o, [&](std::size_t f) {
            return o.faces[f] == std::array<std::int32_t, 3>{0, 2, 4};
        });
        const std::int32_t m = damaged.add_vertex({0.5, 0.5, 0.0});
        damaged.add_face(0, m, 4, 1, 0);
        damaged.add_face(m, 2, 4, 1, 0);
        damaged.add_face(0, 2, m, 1, 0);
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(counter(ctx, "repair.zero_area_faces") == 1);
        CHECK(counter(ctx, "repair.split_faces") == 1);
        CHECK(counter(ctx, "repair.filled_holes") == 0);
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 1) == Approx(4.0 / 3.0));
    }
}

TEST_CASE("repair removes small components and keeps large ones", "[surface]") {
    const SurfaceNetwork sphere = fixtures::uv_sphere(10.0, 16);
    const double v_sphere = core::enclosed_volume(sphere, 1);
    surface::RepairParams params;  // min_component_volume_mm3 = 1
    SurfaceNetwork s = sphere;
    SECTION("a tiny separate piece goes") {
        append(s, translated(fixtures::octahedron(0.5), {30, 0, 0}));
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(s, params, ctx);
        CHECK(counter(ctx, "repair.removed_components") == 1);
        CHECK(counter(ctx, "repair.removed_component_volume_mm3") == Approx(4.0 / 3.0 * 0.125));
        CHECK(out.faces == sphere.faces);
        CHECK(out.xyz == sphere.xyz);
    }
    SECTION("a large separate piece stays") {
        append(s, translated(fixtures::octahedron(3.0), {30, 0, 0}));
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(s, params, ctx);
        CHECK(counter(ctx, "repair.removed_components") == 0);
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 1) == Approx(v_sphere + 36.0));
    }
    SECTION("too few faces goes too") {
        append(s, translated(fixtures::octahedron(3.0), {30, 0, 0}));
        params.min_component_faces = 10;
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(s, params, ctx);
        CHECK(counter(ctx, "repair.removed_components") == 1);
        CHECK(core::enclosed_volume(out, 1) == Approx(v_sphere));
    }
    SECTION("a tiny inclusion of another region goes with its cavity") {
        append(s, labelled(fixtures::octahedron(0.5), 2, 1));
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(s, params, ctx);
        CHECK(counter(ctx, "repair.removed_components") == 2);  // region 2's and region 1's piece
        CHECK(core::region_labels(out) == std::vector<Label>{1});
        CHECK(core::enclosed_volume(out, 1) == Approx(v_sphere));
    }
    SECTION("a tiny region glued onto a large one stays (no interface is torn)") {
        // Region 2: a flat tetrahedron on face (0, 2, 4) of a large octahedron of region 1.
        SurfaceNetwork o = fixtures::octahedron(10.0);
        const Eigen::Vector3d c = (o.point(0) + o.point(2) + o.point(4)) / 3.0;
        const std::int32_t apex = o.add_vertex(c + 0.01 * Eigen::Vector3d(1, 1, 1).normalized());
        for (std::size_t f = 0; f < o.face_count(); ++f)
            if (o.faces[f] == std::array<std::int32_t, 3>{0, 2, 4}) o.region_out[f] = 2;
        o.add_face(0, 2, apex, 2, 0);
        o.add_face(2, 4, apex, 2, 0);
        o.add_face(4, 0, apex, 2, 0);
        const double v2 = core::enclosed_volume(o, 2);
        REQUIRE(v2 > 0.0);
        REQUIRE(v2 < 1.0);
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(o, params, ctx);
        CHECK(counter(ctx, "repair.removed_components") == 0);
        CHECK(core::region_labels(out) == std::vector<Label>{1, 2});
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 2) == Approx(v2));
    }
}

TEST_CASE("repair fills holes", "[surface]") {
    const int n = 16;
    const SurfaceNetwork s = fixtures::uv_sphere(10.0, n);
    const double v = core::enclosed_volume(s, 1);
    core::StageContext ctx;
    SECTION("one missing face") {
        const SurfaceNetwork damaged = without_faces(s, [](std::size_t f) { return f == 100; });
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(counter(ctx, "repair.filled_holes") == 1);
        CHECK(counter(ctx, "repair.hole_faces") == 1);
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 1) == Approx(v).epsilon(1e-12));
    }
    SECTION("the ring of six faces around a vertex") {
        const std::int32_t centre = ring_vertex(n, 5, 7);
        const SurfaceNetwork damaged = without_faces(s, [&](std::size_t f) {
            const auto& t = s.faces[f];
            return std::find(t.begin(), t.end(), centre) != t.end();
        });
        REQUIRE(s.face_count() - damaged.face_count() == 6);
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(counter(ctx, "repair.filled_holes") == 1);
        CHECK(counter(ctx, "repair.hole_faces") == 4);  // a loop of 6 edges takes 4 triangles
        CHECK(counter(ctx, "repair.unused_points") == 1);
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 1) == Approx(v).epsilon(0.01));
        CHECK(core::enclosed_volume(out, 1) < v);  // the patch is flatter than the sphere
    }
    SECTION("two holes touching at a vertex: each filled by itself") {
        // Two faces of the fan around a vertex that share only the vertex: the border is
        // one loop through the vertex twice. Filled as one loop it reused an edge (four faces
        // on it, a non-manifold boundary; campaign seed 11, issue 21).
        const std::int32_t centre = ring_vertex(n, 6, 3);
        std::vector<std::size_t> fan;
        for (std::size_t f = 0; f < s.face_count(); ++f)
            if (std::find(s.faces[f].begin(), s.faces[f].end(), centre) != s.faces[f].end())
                fan.push_back(f);
        REQUIRE(fan.size() == 6);
        const std::size_t first = fan[0];
        std::size_t second = fan[0];
        for (const std::size_t f : fan) {
            int shared = 0;
            for (std::int32_t x : s.faces[first])
                for (std::int32_t y : s.faces[f]) shared += x == y;
            if (shared == 1) second = f;
        }
        REQUIRE(second != first);
        const SurfaceNetwork damaged =
            without_faces(s, [&](std::size_t f) { return f == first || f == second; });
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(counter(ctx, "repair.hole_faces") == 2);
        require_closed_and_oriented(out);
        CHECK(pinch_vertices(out) == 0);
        CHECK(core::enclosed_volume(out, 1) == Approx(v).epsilon(1e-12));
    }
    SECTION("a long curved strip: patched by minimum area, not by a fan") {
        // Column 0 between rings 3 and 10: a hole of 16 edges along a meridian (80 degrees).
        auto in_strip = [&](std::size_t f) {
            const auto& t = s.faces[f];
            for (std::int32_t x : t) {
                if (x == 0 || x > ring_vertex(n, n - 1, 2 * n - 1)) return false;
                const int i = 1 + (x - 1) / (2 * n), j = (x - 1) % (2 * n);
                if (i < 3 || i > 10 || j > 1) return false;
            }
            return true;
        };
        const SurfaceNetwork damaged = without_faces(s, in_strip);
        const double removed = area(s) - area(damaged);
        REQUIRE(s.face_count() - damaged.face_count() == 14);
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(counter(ctx, "repair.hole_faces") == 14);
        require_closed_and_oriented(out);
        CHECK(std::abs(area(out) - area(s)) < 0.05 * removed);
    }
    SECTION("two holes, flipped faces and duplicates at once") {
        const std::int32_t centre = ring_vertex(n, 11, 20);
        SurfaceNetwork damaged = without_faces(s, [&](std::size_t f) {
            const auto& t = s.faces[f];
            return f == 100 || std::find(t.begin(), t.end(), centre) != t.end();
        });
        for (std::size_t f = 0; f < damaged.face_count(); f += 9)
            std::swap(damaged.faces[f][1], damaged.faces[f][2]);
        for (std::size_t f = 3; f < 60; f += 10) {
            const auto t = damaged.faces[f];
            damaged.add_face(t[0], t[1], t[2], 1, 0);
        }
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(counter(ctx, "repair.filled_holes") == 2);
        CHECK(counter(ctx, "repair.duplicate_faces") == 6);
        CHECK(counter(ctx, "repair.flipped_faces") > 0);
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 1) == Approx(v).epsilon(0.01));
    }
    SECTION("a hole in an interface is filled once for both regions") {
        SurfaceNetwork two = s;
        append(two, labelled(fixtures::uv_sphere(5.0, 12), 2, 1));
        const std::size_t inner_face = s.face_count() + 50;
        const SurfaceNetwork damaged =
            without_faces(two, [&](std::size_t f) { return f == inner_face; });
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(counter(ctx, "repair.filled_holes") == 1);
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 2) ==
              Approx(core::enclosed_volume(two, 2)).epsilon(1e-12));
        CHECK(core::enclosed_volume(out, 1) ==
              Approx(core::enclosed_volume(two, 1)).epsilon(1e-12));
    }
}

TEST_CASE("repair refuses holes larger than max_hole_edges", "[surface]") {
    const int n = 16;
    const SurfaceNetwork s = fixtures::uv_sphere(10.0, n);
    // Remove the cap above ring 3: a hole bounded by 2n = 32 edges.
    const double z3 = s.point(ring_vertex(n, 3, 0)).z();
    const SurfaceNetwork damaged = without_faces(s, [&](std::size_t f) {
        const auto& t = s.faces[f];
        return (s.point(t[0]).z() + s.point(t[1]).z() + s.point(t[2]).z()) / 3.0 > z3;
    });
    surface::RepairParams params;
    core::StageContext ctx;
    SECTION("too large: error naming the region and the limit") {
        params.max_hole_edges = 20;
        CHECK_THROWS_AS(surface::repair(damaged, params, ctx), core::GeometryError);
        CHECK_THROWS_WITH(surface::repair(damaged, params, ctx),
                          Catch::Contains("region 1") && Catch::Contains("32 edges") &&
                              Catch::Contains("repair.max_hole_edges"));
    }
    SECTION("within the default: filled") {
        const SurfaceNetwork out = surface::repair(damaged, params, ctx);
        CHECK(counter(ctx, "repair.filled_holes") == 1);
        CHECK(counter(ctx, "repair.hole_faces") == 30);  // a loop of 32 edges takes 30 triangles
        require_closed_and_oriented(out);
        // The flat lid cuts off the spherical cap above ring 3.
        CHECK(core::enclosed_volume(out, 1) < core::enclosed_volume(s, 1));
    }
    SECTION("filling switched off: the open region is an error") {
        params.fill_holes = false;
        CHECK_THROWS_WITH(surface::repair(damaged, params, ctx),
                          Catch::Contains("region 1") && Catch::Contains("not closed"));
    }
}

TEST_CASE("repair splits a pinch vertex between touching bodies", "[surface]") {
    // Two spheres of region 1 touching at one point: A's north pole is B's south pole.
    const SurfaceNetwork a = fixtures::uv_sphere(5.0, 12);
    SurfaceNetwork s = a;
    append(s, translated(a, {0, 0, 10}));
    SECTION("on the outer boundary: split, each body closed and manifold") {
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(s, {}, ctx);
        CHECK(counter(ctx, "repair.merged_points") == 1);
        CHECK(counter(ctx, "repair.split_vertices") == 1);
        CHECK(out.vertex_count() == s.vertex_count());
        CHECK(pinch_vertices(out) == 0);
        require_closed_and_oriented(out);
        // Each copy moved into its own body (coincident copies made remesh see crossing
        // faces): the bodies no longer touch, and lose a sliver of volume.
        CHECK((out.point(static_cast<std::int32_t>(out.vertex_count() - 1)) -
               out.point(static_cast<std::int32_t>(a.vertex_count() - 1)))
                  .norm() > 0.01);
        CHECK(core::enclosed_volume(out, 1) ==
              Approx(2.0 * core::enclosed_volume(a, 1)).epsilon(1e-3));
    }
    SECTION("inside another region: kept as one vertex") {
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(inside_sphere(s), {}, ctx);
        CHECK(counter(ctx, "repair.split_vertices") == 0);
        CHECK(counter(ctx, "repair.kept_pinch_vertices") == 1);
        CHECK(pinch_vertices(out) == 2);  // the same vertex, seen from regions 1 and 2
        require_closed_and_oriented(out);
    }
}

TEST_CASE("repair refuses bodies touching along an edge, and keeps such an edge inside",
          "[surface]") {
    // Two octahedra of region 1 touching along one edge: (1,0,0)-(0,1,0) of the first is
    // (-1,0,0)-(0,-1,0) of the second moved by (1,1,0). Four faces of region 1 on that edge.
    const SurfaceNetwork o = fixtures::octahedron(1.0);
    SurfaceNetwork s = o;
    append(s, translated(o, {1, 1, 0}));
    SECTION("on the outer boundary: bad input, since the referee needs a manifold boundary") {
        core::StageContext ctx;
        CHECK_THROWS_AS(surface::repair(s, {}, ctx), core::InputError);
        CHECK_THROWS_WITH(surface::repair(s, {}, ctx),
                          Catch::Contains("outer boundary is not a manifold at edge") &&
                              Catch::Contains("near (0.5, 0.5, 0) mm"));
    }
    SECTION("inside another region: kept and reported") {
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(inside_sphere(s), {}, ctx);
        CHECK(counter(ctx, "repair.merged_points") == 2);
        CHECK(counter(ctx, "repair.nonmanifold_edges") == 2);  // once for regions 1 and 2
        CHECK(counter(ctx, "repair.split_vertices") == 0);
        CHECK(has_warning(ctx, "non-manifold edges"));
        require_closed_and_oriented_but_edges(out, 2);
        CHECK(core::enclosed_volume(out, 2) == Approx(8.0 / 3.0));
    }
}

TEST_CASE("repair keeps a two-region network as it is", "[surface]") {
    // Region 2: inner sphere (faces 2|1, outward from 2); region 1: the shell between the
    // spheres, whose boundary is the outer sphere (1|0) and the inner sphere seen reversed.
    const SurfaceNetwork outer = fixtures::uv_sphere(10.0, 16);
    const SurfaceNetwork inner = labelled(fixtures::uv_sphere(5.0, 12), 2, 1);
    SurfaceNetwork s = outer;
    append(s, inner);
    const double v1 = core::enclosed_volume(outer, 1) - core::enclosed_volume(inner, 2);
    REQUIRE(core::enclosed_volume(s, 1) == Approx(v1));
    SurfaceNetwork damaged = s;
    std::size_t flipped = 0;
    SECTION("undamaged") {}
    SECTION("the inner sphere inside out") {
        for (std::size_t f = outer.face_count(); f < s.face_count(); ++f)
            std::swap(damaged.faces[f][1], damaged.faces[f][2]);
        flipped = inner.face_count();
    }
    SECTION("random flips on both, and interface duplicates with their labels swapped") {
        std::mt19937 rng(7);
        std::bernoulli_distribution coin(0.1);
        for (auto& t : damaged.faces)
            if (coin(rng)) {
                std::swap(t[1], t[2]);
                ++flipped;
            }
        for (std::size_t f = outer.face_count(); f < s.face_count(); f += 25) {
            const auto t = damaged.faces[f];
            damaged.add_face(t[0], t[2], t[1], 1, 2);  // the same face, stated from region 1
        }
    }
    core::StageContext ctx;
    const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
    CHECK(out.faces == s.faces);
    CHECK(out.region_in == s.region_in);
    CHECK(out.region_out == s.region_out);
    CHECK(counter(ctx, "repair.flipped_faces") == static_cast<double>(flipped));
    require_closed_and_oriented(out);
    CHECK(core::enclosed_volume(out, 1) == Approx(v1));
    CHECK(core::enclosed_volume(out, 2) == Approx(core::enclosed_volume(inner, 2)));
}

TEST_CASE("repair orients the cavity wall of a hollow region inward", "[surface]") {
    // Region 1 is a hollow ball: its inner wall (1|0) faces the empty cavity.
    const SurfaceNetwork outer = fixtures::uv_sphere(10.0, 16);
    const SurfaceNetwork wall = fixtures::uv_sphere(5.0, 12);
    SurfaceNetwork s = outer;
    append(s, reversed(wall));
    const double v1 = core::enclosed_volume(outer, 1) - core::enclosed_volume(wall, 1);
    SECTION("correct: unchanged") {
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(s, {}, ctx);
        CHECK(out.faces == s.faces);
        CHECK(counter(ctx, "repair.flipped_faces") == 0);
    }
    SECTION("the wall facing the wrong way: flipped by nesting") {
        SurfaceNetwork damaged = outer;
        append(damaged, wall);
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(out.faces == s.faces);
        CHECK(counter(ctx, "repair.flipped_faces") == static_cast<double>(wall.face_count()));
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 1) == Approx(v1));
    }
    SECTION("the wall facing the wrong way while the outer sphere has a hole") {
        SurfaceNetwork damaged = without_faces(outer, [](std::size_t f) { return f == 200; });
        append(damaged, wall);
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(damaged, {}, ctx);
        CHECK(counter(ctx, "repair.flipped_faces") == static_cast<double>(wall.face_count()));
        CHECK(counter(ctx, "repair.filled_holes") == 1);
        require_closed_and_oriented(out);
        CHECK(core::enclosed_volume(out, 1) == Approx(v1));
    }
}

TEST_CASE("repair detects self-intersections", "[surface]") {
    // Two overlapping spheres of the same region: closed and oriented, but crossing.
    const SurfaceNetwork a = fixtures::uv_sphere(5.0, 12);
    SurfaceNetwork s = a;
    append(s, translated(a, {3.0, 0.2, 0.1}));
    surface::RepairParams params;
    SECTION("error by default") {
        core::StageContext ctx;
        CHECK_THROWS_AS(surface::repair(s, params, ctx), core::GeometryError);
        CHECK_THROWS_WITH(
            surface::repair(s, params, ctx),
            Catch::Contains("self-intersecting face pairs") && Catch::Contains("near ("));
    }
    SECTION("a warning when asked") {
        params.fail_on_self_intersections = false;
        core::StageContext ctx;
        const SurfaceNetwork out = surface::repair(s, params, ctx);
        CHECK(has_warning(ctx, "self-intersecting face pairs"));
        CHECK(counter(ctx, "repair.self_intersecting_pairs") > 0);
        require_closed_and_oriented(out);
    }
    SECTION("nothing when the check is off") {
        params.check_self_intersections = false;
        core::StageContext ctx;
        CHECK_NOTHROW(surface::repair(s, params, ctx));
        CHECK(ctx.warnings().empty());
    }
}

TEST_CASE("repair validates parameters and input", "[surface]") {
    surface::RepairParams params;
    CHECK_NOTHROW(surface::validate(params));
    SECTION("negative tolerance") {
        params.merge_tolerance_mm = -1e-6;
        CHECK_THROWS_AS(surface::validate(params), core::InputError);
        CHECK_THROWS_WITH(surface::validate(params), Catch::Contains("repair.merge_tolerance_mm"));
    }
    SECTION("volume not a number") {
        params.min_component_volume_mm3 = std::nan("");
        CHECK_THROWS_WITH(surface::validate(params),
                          Catch::Contains("repair.min_component_volume_mm3"));
    }
    SECTION("hole limit beyond what can be filled") {
        params.max_hole_edges = 1000000;
        CHECK_THROWS_WITH(surface::validate(params), Catch::Contains("repair.max_hole_edges"));
    }
    SECTION("repair checks its parameters and its input") {
        core::StageContext ctx;
        SurfaceNetwork s = fixtures::octahedron(1.0);
        params.merge_tolerance_mm = -1.0;
        CHECK_THROWS_AS(surface::repair(s, params, ctx), core::InputError);
        params = {};
        s.region_in[3] = 0;
        CHECK_THROWS_WITH(surface::repair(s, params, ctx), Catch::Contains("face 3"));
        s = fixtures::octahedron(1.0);
        s.faces[2][1] = 99;
        CHECK_THROWS_WITH(surface::repair(s, params, ctx), Catch::Contains("vertex 99"));
        CHECK_THROWS_AS(surface::repair(SurfaceNetwork{}, params, ctx), core::InputError);
    }
}

TEST_CASE("repair is deterministic", "[surface]") {
    const SurfaceNetwork s = fixtures::uv_sphere(10.0, 16);
    SurfaceNetwork damaged = without_faces(s, [](std::size_t f) { return f % 97 == 13; });
    std::mt19937 rng(99);
    std::bernoulli_distribution coin(0.2);
    for (auto& t : damaged.faces)
        if (coin(rng)) std::swap(t[0], t[1]);
    for (std::size_t f = 0; f < 50; f += 7) {
        const auto t = damaged.faces[f];
        damaged.add_face(t[2], t[0], t[1], 1, 0);
    }
    core::StageContext c1, c2;
    const SurfaceNetwork r1 = surface::repair(damaged, {}, c1);
    const SurfaceNetwork r2 = surface::repair(damaged, {}, c2);
    CHECK(r1.xyz == r2.xyz);
    CHECK(r1.faces == r2.faces);
    CHECK(r1.region_in == r2.region_in);
    CHECK(r1.region_out == r2.region_out);
    CHECK(c1.counters() == c2.counters());
    require_closed_and_oriented(r1);
}
