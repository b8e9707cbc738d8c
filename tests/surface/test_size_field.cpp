#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include <catch2/catch.hpp>

#include "pipeline/core/error.h"
#include "surface/features.h"
#include "surface/size_field.h"
#include "tests/fixtures/phantoms.h"

using namespace frontmesh;

namespace {

// Sizes of the vertices on the slab's big faces at least `margin` from the rim.
std::vector<double> middle_sizes(const core::SurfaceNetwork& s, const surface::SizeField& f,
                                 double a, double margin) {
    std::vector<double> out;
    for (std::size_t v = 0; v < s.vertex_count(); ++v) {
        const auto p = s.point(std::int32_t(v));
        if (p.x() > margin && p.x() < a - margin && p.y() > margin && p.y() < a - margin)
            out.push_back(f.at_vertex(std::int32_t(v)));
    }
    return out;
}

}  // namespace

TEST_CASE("grid box fixture is closed and outward", "[remesh]") {
    const auto s = fixtures::grid_box(10, 10, 1, 0.5);
    const auto checks = core::check_region_boundaries(s);
    REQUIRE(checks.size() == 1);
    CHECK(checks[0].is_closed());
    CHECK(checks[0].is_oriented());
    CHECK(checks[0].volume == Approx(100.0));
}

TEST_CASE("size field: uniform on a ball, thin slab limited by its thickness", "[remesh]") {
    core::StageContext ctx;
    SECTION("uniform: a thick body keeps h everywhere") {
        const auto s = fixtures::uv_sphere(10.0, 48);
        surface::SizeFieldParams p;
        p.edge_length = 2.0;
        const auto f = surface::build_size_field(s, p, ctx);
        for (const double x : f.vertex_sizes()) CHECK(x == Approx(2.0));
    }
    const double a = 20.0, t = 1.0;
    const auto slab = fixtures::grid_box(a, a, t, 0.5);
    surface::SizeFieldParams p;
    p.edge_length = 3.0;
    p.min_edge_length = 0.1;
    SECTION("two sheets closer than h: h <= their distance") {
        const auto f = surface::build_size_field(slab, p, ctx);
        const auto mid = middle_sizes(slab, f, a, 2.0);
        REQUIRE(!mid.empty());
        for (const double x : mid) CHECK(x <= t + 1e-9);
        CHECK(*std::max_element(mid.begin(), mid.end()) == Approx(t).epsilon(1e-6));
    }
    SECTION("thickness layers: N layers across") {
        p.thickness_layers = 4;
        const auto f = surface::build_size_field(slab, p, ctx);
        const auto mid = middle_sizes(slab, f, a, 2.0);
        for (const double x : mid) CHECK(x == Approx(t / 4).epsilon(1e-6));
    }
    SECTION("the min clamp wins and is reported") {
        p.min_edge_length = 2.0;
        surface::SizeFieldStats stats;
        const auto f = surface::build_size_field(slab, p, ctx, &stats);
        for (const double x : f.vertex_sizes()) CHECK(x >= 2.0 - 1e-12);
        CHECK(stats.gap_below_min > 0);
        CHECK_FALSE(ctx.warnings().empty());
    }
}

TEST_CASE("size field: a narrow gap between two boxes", "[remesh]") {
    auto s = fixtures::grid_box(10, 10, 4, 0.5);
    auto upper = fixtures::grid_box(10, 10, 4, 0.5);
    const auto offset = std::int32_t(s.vertex_count());
    for (std::size_t v = 0; v < upper.vertex_count(); ++v)
        s.add_vertex(upper.point(std::int32_t(v)) + Eigen::Vector3d(0, 0, 4.6));
    for (std::size_t f = 0; f < upper.face_count(); ++f) {
        const auto& t = upper.faces[f];
        s.add_face(t[0] + offset, t[1] + offset, t[2] + offset, 1, 0);
    }
    surface::SizeFieldParams p;
    p.edge_length = 2.0;
    core::StageContext ctx;
    const auto f = surface::build_size_field(s, p, ctx);
    // Facing sides of the gap (z = 4 and z = 4.6), away from the rims.
    for (std::size_t v = 0; v < s.vertex_count(); ++v) {
        const auto q = s.point(std::int32_t(v));
        if (q.x() < 2 || q.x() > 8 || q.y() < 2 || q.y() > 8) continue;
        if (std::abs(q.z() - 4.0) < 1e-9 || std::abs(q.z() - 4.6) < 1e-9)
            CHECK(f.at_vertex(std::int32_t(v)) <= 0.6 + 1e-9);
        if (std::abs(q.z()) < 1e-9) CHECK(f.at_vertex(std::int32_t(v)) > 0.6);  // far side
    }
}

TEST_CASE("size field: gradation limit holds on every edge", "[remesh]") {
    const auto s = fixtures::grid_box(20, 20, 1, 0.5);
    core::StageContext ctx;
    for (const double g : {1.1, 1.3, 2.0}) {
        surface::SizeFieldParams p;
        p.edge_length = 4.0;
        p.gradation = g;
        p.min_edge_length = 0.05;
        const auto f = surface::build_size_field(s, p, ctx);
        const auto et = surface::edge_table(s);
        std::size_t bad = 0;
        for (const auto& e : et.vertices) {
            const double len = (s.point(e[0]) - s.point(e[1])).norm();
            const double du = std::abs(f.at_vertex(e[0]) - f.at_vertex(e[1]));
            if (du > (g - 1.0) * len + 1e-9) ++bad;
        }
        CHECK(bad == 0);
        // The gap limit (1 mm) spreads from the slab with slope g - 1 at most.
        CHECK(*std::max_element(f.vertex_sizes().begin(), f.vertex_sizes().end()) <= 4.0);
    }
}

TEST_CASE("size field: curvature limit, per-label sizes, queries, validation", "[remesh]") {
    core::StageContext ctx;
    const auto s = fixtures::uv_sphere(10.0, 96);
    surface::SizeFieldParams p;
    p.edge_length = 5.0;
    p.max_edge_length = 5.0;
    SECTION("the turning angle per edge stays near the limit: h ~ angle * R") {
        p.curvature_angle_deg = 10.0;
        const auto f = surface::build_size_field(s, p, ctx);
        const double expected = 10.0 * 3.14159265 / 180.0 * 10.0;  // 1.745 mm
        std::vector<double> sizes = f.vertex_sizes();
        std::sort(sizes.begin(), sizes.end());
        const double median = sizes[sizes.size() / 2];
        CHECK(median == Approx(expected).epsilon(0.15));
    }
    SECTION("a label size applies to its faces' vertices") {
        p.label_edge_length[1] = 1.5;
        const auto f = surface::build_size_field(s, p, ctx);
        for (const double x : f.vertex_sizes()) CHECK(x == Approx(1.5));
        // Query inside a face interpolates the vertex sizes.
        const auto& t = s.faces[10];
        const Eigen::Vector3d c = (s.point(t[0]) + s.point(t[1]) + s.point(t[2])) / 3.0;
        CHECK(f.at(c, 10) == Approx(1.5));
        CHECK(f.at(c, -1) == Approx(1.5));
    }
    SECTION("bad parameters name the key") {
        p.edge_length = 0.0;
        CHECK_THROWS_WITH(surface::build_size_field(s, p, ctx),
                          Catch::Contains("remesh.edge_length"));
        p.edge_length = 1.0;
        p.gradation = 0.5;
        CHECK_THROWS_AS(surface::build_size_field(s, p, ctx), core::InputError);
    }
}
