// Remesh on the torture corpus's smallest inputs (issue 20): 2 x 2 x 2 label images whose
// regions meet at one point or along one voxel edge, meshed with an edge length larger than
// the regions themselves.

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <catch2/catch.hpp>

#include "pipeline/core/error.h"
#include "pipeline/core/label_image.h"
#include "pipeline/core/self_intersection.h"
#include "surface/extract.h"
#include "surface/remesh.h"
#include "surface/remesh_internal.h"
#include "surface/repair.h"

using namespace frontmesh;

namespace {

// A 2 x 2 x 2 block of labels (x fastest) in an image padded by one voxel of outside, as the
// image reader pads it.
core::LabelImage cube_image(const std::array<core::Label, 8>& block, double spacing) {
    core::LabelImage image;
    image.dims = {4, 4, 4};
    image.spacing = Eigen::Vector3d::Constant(spacing);
    image.origin = Eigen::Vector3d::Constant(-1.5 * spacing);
    image.labels.assign(image.voxel_count(), 0);
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i)
                image.labels[image.index(i + 1, j + 1, k + 1)] =
                    block[std::size_t(i + 2 * j + 4 * k)];
    image.source = "2x2x2 block";
    return image;
}

core::SurfaceNetwork background_of(const core::LabelImage& image) {
    core::StageContext ctx;
    return surface::repair(surface::extract(image, {}, ctx), {}, ctx);
}

// Every region closed, oriented with positive volume, manifold; no faces crossing.
void check_valid(const core::SurfaceNetwork& bg, const surface::RemeshResult& r) {
    REQUIRE(r.surface.face_count() > 0);
    CHECK(core::region_labels(r.surface) == core::region_labels(bg));
    for (const auto& c : core::check_region_boundaries(r.surface)) {
        INFO("region " << c.region);
        CHECK(c.is_closed());
        CHECK(c.is_oriented());
        CHECK(c.nonmanifold_edges == 0);
        CHECK(c.volume > 0.1 * core::enclosed_volume(bg, c.region));
    }
    CHECK(core::self_intersections(r.surface, 1).empty());
}

}  // namespace

TEST_CASE("remesh 2x2x2 label blocks with an edge length larger than the regions",
          "[remesh][torture]") {
    // The torture corpus's cube seeds 19, 51, 59, 91 and 115 (labels x fastest, then y, z),
    // with their voxel size and edge length.
    struct Case {
        std::array<core::Label, 8> block;
        double spacing, h;
    };
    const std::vector<Case> cases = {
        {{0, 0, 0, 1, 0, 0, 0, 2}, 10.0, 23.74},    {{0, 0, 0, 2, 0, 1, 0, 0}, 10.0, 13.221},
        {{0, 0, 0, 2, 0, 1, 0, 1}, 100.0, 220.431}, {{0, 1, 0, 2, 0, 1, 0, 2}, 100.0, 234.743},
        {{0, 1, 0, 2, 0, 2, 0, 3}, 10.0, 18.263},
    };
    for (const Case& c : cases) {
        INFO("block " << c.block[0] << c.block[1] << c.block[2] << c.block[3] << c.block[4]
                      << c.block[5] << c.block[6] << c.block[7] << ", voxels " << c.spacing
                      << " mm, h " << c.h << " mm");
        const core::SurfaceNetwork bg = background_of(cube_image(c.block, c.spacing));
        surface::RemeshParams params;
        params.edge_length = c.h;
        core::StageContext ctx;
        const surface::RemeshResult r = surface::remesh(bg, params, ctx);
        check_valid(bg, r);
    }
}

TEST_CASE("remesh of random labels ends within its work budget (issue 21)", "[remesh][torture]") {
    // An 8^3 block of seven random labels (1 mm voxels): thousands of patches a voxel across,
    // whose stalls once made the rounds mesh ever more of them finer (a 16^3 block ran for
    // more than ten minutes). RetryPolicy::spend bounds the stage's work by
    // (kWorkBudget + 64) times the first round's.
    core::LabelImage image;
    image.dims = {10, 10, 10};
    image.spacing = Eigen::Vector3d::Ones();
    image.origin = Eigen::Vector3d::Zero();
    image.labels.assign(image.voxel_count(), 0);
    std::uint32_t state = 3;  // a fixed linear congruential sequence: the same block everywhere
    for (int k = 1; k < 9; ++k)
        for (int j = 1; j < 9; ++j)
            for (int i = 1; i < 9; ++i) {
                state = state * 1664525u + 1013904223u;
                image.labels[image.index(i, j, k)] = core::Label((state >> 16) % 7);
            }
    image.source = "random block";
    const core::SurfaceNetwork bg = background_of(image);
    core::StageContext ctx;
    const surface::RemeshResult r = surface::remesh(bg, surface::RemeshParams{}, ctx);
    check_valid(bg, r);
    const double ratio = ctx.counters().at("remesh.work_ratio");
    INFO("work ratio " << ratio << ", rounds " << ctx.counters().at("remesh.rounds"));
    CHECK(ratio <= surface::remesh_detail::RetryPolicy::kWorkBudget + 64.0);
    bool budget_named = false;
    for (const auto& w : ctx.warnings())
        budget_named |= w.find("times the first round's") != std::string::npos;
    CHECK(budget_named == (ratio > surface::remesh_detail::RetryPolicy::kWorkBudget));
}
