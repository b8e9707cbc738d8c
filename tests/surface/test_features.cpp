#include <algorithm>
#include <map>
#include <set>

#include <catch2/catch.hpp>

#include "pipeline/core/label_image.h"
#include "surface/extract.h"
#include "surface/features.h"
#include "surface/repair.h"
#include "tests/fixtures/phantoms.h"

using namespace frontmesh;

namespace {

core::SurfaceNetwork network_of(const core::LabelImage& image) {
    core::StageContext ctx;
    surface::ExtractParams params;
    params.method = surface::ExtractMethod::SurfaceNets;
    return surface::repair(surface::extract(image, params, ctx), {}, ctx);
}

}  // namespace

TEST_CASE("features of a split ball: one junction circle shared by three patches", "[remesh]") {
    const auto bg = network_of(fixtures::split_ball_image(40, 14.0));
    core::StageContext ctx;
    const auto f = surface::find_features(bg, 0.0, ctx);
    REQUIRE(f.patches.size() == 3);
    CHECK(f.junction_edges > 0);
    CHECK(f.sharp_edges == 0);
    // The junction is one closed curve without corners.
    REQUIRE(f.curves.size() == 1);
    CHECK(f.curves[0].is_closed);
    CHECK(f.corners.empty());
    CHECK(f.curves[0].vertices.front() == f.curves[0].vertices.back());
    // Every curve vertex lies where all three labels meet (z near 0) and every curve edge
    // has three faces, one of each patch.
    const auto& cv = f.curves[0].vertices;
    for (std::size_t i = 0; i + 1 < cv.size(); ++i) {
        CHECK(std::abs(bg.point(cv[i]).z() - 19.5) < 1.5);
    }
    std::set<std::pair<core::Label, core::Label>> pairs;
    for (const auto& p : f.patches) {
        pairs.insert({p.region_in, p.region_out});
        // Each patch is bounded by the curve once, in its own direction.
        REQUIRE(p.loops.size() == 1);
        REQUIRE(p.loops[0].size() == 1);
        CHECK(p.loops[0][0].curve == 0);
        for (const auto face : p.faces) CHECK(f.face_patch[std::size_t(face)] >= 0);
    }
    CHECK(pairs.size() == 3);
    // The two hemisphere caps and the disc: the caps use the curve in opposite directions
    // relative to each other only through the disc; at least one forward and one backward.
    int forward = 0;
    for (const auto& p : f.patches) forward += p.loops[0][0].forward ? 1 : 0;
    CHECK(forward >= 1);
    CHECK(forward <= 2);
}

TEST_CASE("features of the nested phantom: three closed patches, no curves", "[remesh]") {
    const auto bg = network_of(fixtures::nested_ellipsoids_image(1.0, 0.6));
    core::StageContext ctx;
    const auto f = surface::find_features(bg, 0.0, ctx);
    CHECK(f.patches.size() == 3);
    CHECK(f.curves.empty());
    for (const auto& p : f.patches) CHECK(p.loops.empty());
    CHECK(ctx.counters().at("remesh.patches") == 3.0);
}

TEST_CASE("sharp edges split a cube into six patches with eight corners", "[remesh]") {
    // A cube made of two triangles per side, labelled 1 inside.
    core::SurfaceNetwork s;
    for (int i = 0; i < 8; ++i) s.add_vertex(Eigen::Vector3d(i & 1, (i >> 1) & 1, (i >> 2) & 1));
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                             {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
        s.add_face(q[0], q[1], q[2], 1, 0);
        s.add_face(q[0], q[2], q[3], 1, 0);
    }
    const auto checks = core::check_region_boundaries(s);
    REQUIRE(checks.size() == 1);
    REQUIRE(checks[0].is_oriented());
    core::StageContext ctx;
    SECTION("off by default: one closed patch") {
        const auto f = surface::find_features(s, 0.0, ctx);
        CHECK(f.patches.size() == 1);
        CHECK(f.curves.empty());
    }
    SECTION("at 30 degrees: the 12 cube edges, 8 corners, 6 patches of one loop each") {
        const auto f = surface::find_features(s, 30.0, ctx);
        CHECK(f.sharp_edges == 12);
        CHECK(f.corners.size() == 8);
        CHECK(f.curves.size() == 12);
        REQUIRE(f.patches.size() == 6);
        for (const auto& p : f.patches) {
            REQUIRE(p.loops.size() == 1);
            CHECK(p.loops[0].size() == 4);
            // Consecutive uses meet at a corner.
            for (std::size_t k = 0; k < 4; ++k) {
                const auto& a = p.loops[0][k];
                const auto& b = p.loops[0][(k + 1) % 4];
                const auto& ca = f.curves[std::size_t(a.curve)].vertices;
                const auto& cb = f.curves[std::size_t(b.curve)].vertices;
                CHECK((a.forward ? ca.back() : ca.front()) == (b.forward ? cb.front() : cb.back()));
            }
        }
        // Each curve is used by exactly two patches, once in each direction.
        std::map<int, std::pair<int, int>> uses;
        for (const auto& p : f.patches)
            for (const auto& u : p.loops[0])
                (u.forward ? uses[u.curve].first : uses[u.curve].second)++;
        for (const auto& [c, fb] : uses) {
            CHECK(fb.first == 1);
            CHECK(fb.second == 1);
        }
    }
}
