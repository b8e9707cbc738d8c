// Component thresholds on voxel volumes, and the record of components not meshed (issue 20,
// item 5): extract + repair on small synthetic images.

#include <algorithm>
#include <string>

#include <catch2/catch.hpp>

#include "pipeline/core/error.h"
#include "surface/extract.h"
#include "surface/label_components.h"
#include "surface/repair.h"
#include "tests/fixtures/phantoms.h"

using namespace frontmesh;

namespace {

// An n^3 image of 0 with `spacing` mm voxels, origin 0.
core::LabelImage empty_image(int n, double spacing = 1.0) {
    core::LabelImage image;
    image.dims = {n, n, n};
    image.spacing = Eigen::Vector3d::Constant(spacing);
    image.labels.assign(image.voxel_count(), 0);
    image.source = "synthetic";
    return image;
}

void fill_box(core::LabelImage& image, std::array<int, 3> lo, std::array<int, 3> hi,
              core::Label label) {
    for (int k = lo[2]; k <= hi[2]; ++k)
        for (int j = lo[1]; j <= hi[1]; ++j)
            for (int i = lo[0]; i <= hi[0]; ++i) image.labels[image.index(i, j, k)] = label;
}

// What the recipe reader hands the two stages for an image input.
struct ImageRun {
    core::SurfaceNetwork surface;
    core::StageContext extract_ctx, repair_ctx;
};

ImageRun extract_and_repair(const core::LabelImage& image, double min_volume_mm3,
                            surface::ExtractParams extract = {}) {
    ImageRun run;
    extract.min_component_volume_mm3 = min_volume_mm3;
    surface::RepairParams repair;
    repair.min_component_volume_mm3 = min_volume_mm3;
    repair.is_from_image = true;
    run.surface =
        surface::repair(surface::extract(image, extract, run.extract_ctx), repair, run.repair_ctx);
    return run;
}

bool any_warning(const core::StageContext& ctx, const std::string& a, const std::string& b = "") {
    return std::any_of(ctx.warnings().begin(), ctx.warnings().end(), [&](const std::string& w) {
        return w.find(a) != std::string::npos && w.find(b) != std::string::npos;
    });
}

void require_closed_and_oriented(const core::SurfaceNetwork& s) {
    for (const auto& c : core::check_region_boundaries(s)) {
        INFO("region " << c.region);
        CHECK(c.is_closed());
        CHECK(c.is_oriented());
    }
}

}  // namespace

TEST_CASE("label_components: faces join voxels, edges and corners do not", "[surface]") {
    auto image = empty_image(6);
    fill_box(image, {1, 1, 1}, {2, 2, 1}, 3);  // 2 x 2 x 1
    image.labels[image.index(3, 3, 2)] = 3;    // touches the block only at a corner
    image.labels[image.index(4, 1, 4)] = 5;    // alone
    const auto comps = surface::label_components(image.dims, image.labels);
    REQUIRE(comps.list.size() == 4);  // the outside, the block, the corner voxel, label 5
    const auto& outside = comps.list[0];
    CHECK(outside.label == 0);
    CHECK(outside.touches_border);
    CHECK(outside.voxels == 216 - 6);
    const auto& block = comps.list[static_cast<std::size_t>(comps.of_voxel[image.index(1, 1, 1)])];
    CHECK(block.label == 3);
    CHECK(block.voxels == 4);
    CHECK(block.surrounding == 0);
    CHECK_FALSE(block.touches_border);
    CHECK(block.centre_index.isApprox(Eigen::Vector3d(1.5, 1.5, 1.0)));
    CHECK(comps.of_voxel[image.index(3, 3, 2)] != comps.of_voxel[image.index(2, 2, 1)]);
}

TEST_CASE("extract + repair keep a 2 x 2 x 1 island of 1 mm voxels at the default limit",
          "[surface]") {
    // The island's surface-nets surface encloses about 0.3 mm^3, its voxels 4 mm^3: the limit
    // (1 mm^3) is on the voxels, so it stays.
    auto image = fixtures::sphere_image(32, 8.0, 1.0, 1);
    fill_box(image, {26, 26, 26}, {27, 27, 26}, 1);
    const ImageRun run =
        extract_and_repair(image, surface::RepairParams{}.min_component_volume_mm3);
    require_closed_and_oriented(run.surface);
    CHECK(run.extract_ctx.dropped_components().empty());
    CHECK(run.repair_ctx.dropped_components().empty());
    CHECK(run.extract_ctx.counters().at("extract.dropped_components") == 0);
    CHECK(run.repair_ctx.counters().at("repair.removed_components") == 0);
    // Some faces of region 1 lie near the island.
    bool near_island = false;
    for (std::size_t f = 0; f < run.surface.face_count(); ++f)
        near_island = near_island || (run.surface.point(run.surface.faces[f][0]) -
                                      image.physical(Eigen::Vector3d(26.5, 26.5, 26)))
                                             .norm() < 1.5;
    CHECK(near_island);
}

TEST_CASE("extract names a one-voxel island below the limit: label, voxels, position",
          "[surface]") {
    auto image = fixtures::sphere_image(48, 6.0, 0.5, 1);  // 0.125 mm^3 voxels
    image.labels[image.index(40, 5, 40)] = 2;
    const Eigen::Vector3d at = image.physical(Eigen::Vector3d(40, 5, 40));
    const ImageRun run = extract_and_repair(image, 0.2);
    require_closed_and_oriented(run.surface);
    CHECK(core::region_labels(run.surface) == std::vector<core::Label>{1});
    REQUIRE(run.extract_ctx.dropped_components().size() == 1);
    const core::DroppedComponent& d = run.extract_ctx.dropped_components()[0];
    CHECK(d.label == 2);
    CHECK(d.voxels == 1);
    CHECK(Eigen::Vector3d(d.position_mm[0], d.position_mm[1], d.position_mm[2]).isApprox(at));
    CHECK_THAT(d.reason, Catch::Contains("repair.min_component_volume_mm3"));
    CHECK(any_warning(run.extract_ctx, "label 2: component of 1 voxel",
                      "repair.min_component_volume_mm3"));
    // The label has no face left: that is always said, in its own line.
    CHECK(any_warning(run.extract_ctx, "label 2 is not meshed at all"));
    // The same island at the default limit (1 mm^3 > 0.125 mm^3) goes too, named.
    const ImageRun defaults = extract_and_repair(image, 1.0);
    CHECK(defaults.extract_ctx.dropped_components().size() == 1);
    // Under a lower limit it stays.
    const ImageRun kept = extract_and_repair(image, 0.1);
    CHECK(core::region_labels(kept.surface) == std::vector<core::Label>{1, 2});
    CHECK(kept.extract_ctx.warnings().empty());
}

TEST_CASE("extract fills a small cavity inside one label, keeps islands between labels",
          "[surface]") {
    auto image = empty_image(12);
    fill_box(image, {1, 1, 1}, {10, 10, 5}, 1);
    fill_box(image, {1, 1, 6}, {10, 10, 10}, 2);
    image.labels[image.index(4, 4, 3)] = 0;  // a one-voxel cavity in label 1
    image.labels[image.index(7, 7, 5)] = 3;  // a one-voxel island of 3 touching 1 and 2
    const ImageRun run = extract_and_repair(image, 2.0);
    require_closed_and_oriented(run.surface);
    CHECK(run.extract_ctx.counters().at("extract.filled_cavities") == 1);
    CHECK(run.extract_ctx.counters().at("extract.small_components_kept") == 1);
    CHECK(core::region_labels(run.surface) == std::vector<core::Label>{1, 2, 3});
    CHECK(run.extract_ctx.dropped_components().empty());
}

TEST_CASE("extract names a component its voxel clean-up removed", "[surface]") {
    auto image = fixtures::sphere_image(32, 8.0, 1.0, 1);
    image.labels[image.index(27, 27, 27)] = 1;  // a speck the opening removes
    surface::ExtractParams params;
    params.opening_voxels = 1;
    const ImageRun run = extract_and_repair(image, 0.5, params);
    REQUIRE(run.extract_ctx.dropped_components().size() == 1);
    CHECK(run.extract_ctx.dropped_components()[0].voxels == 1);
    CHECK_THAT(run.extract_ctx.dropped_components()[0].reason,
               Catch::Contains("extract.opening_voxels"));
    CHECK(any_warning(run.extract_ctx, "label 1: component of 1 voxel", "not meshed"));
}

TEST_CASE("a blurred flying-edges mask drops its specks by their voxels", "[surface]") {
    // A 3 x 3 x 3 speck survives a 0.5 mm blur; a limit above 27 mm^3 removes it, and the
    // contour has then one piece.
    auto image = fixtures::sphere_image(40, 10.0, 1.0, 1);
    fill_box(image, {33, 33, 33}, {35, 35, 35}, 1);
    surface::ExtractParams params;
    params.blur_sigma_mm = 0.5;
    const ImageRun kept = extract_and_repair(image, 20.0, params);
    const ImageRun dropped = extract_and_repair(image, 40.0, params);
    CHECK(kept.extract_ctx.dropped_components().empty());
    REQUIRE(dropped.extract_ctx.dropped_components().size() == 1);
    CHECK(dropped.extract_ctx.dropped_components()[0].voxels >= 8);
    require_closed_and_oriented(dropped.surface);
    CHECK(core::enclosed_volume(dropped.surface, 1) < core::enclosed_volume(kept.surface, 1) - 8.0);
}

TEST_CASE("an image whose every component is below the limit is meshed whole", "[surface]") {
    SECTION("2 x 2 x 2 labels of 100 mm voxels") {
        auto image = empty_image(4, 100.0);
        fill_box(image, {1, 1, 1}, {2, 2, 2}, 1);
        image.labels[image.index(2, 2, 2)] = 2;
        image.labels[image.index(1, 2, 2)] = 3;
        const ImageRun run = extract_and_repair(image, 1.0);
        require_closed_and_oriented(run.surface);
        CHECK(core::region_labels(run.surface) == std::vector<core::Label>{1, 2, 3});
    }
    SECTION("two voxels of 1 mm, a limit of 1 mm^3 (torture seed 11)") {
        auto image = empty_image(4, 1.0);
        fill_box(image, {1, 1, 1}, {2, 1, 1}, 1);
        const ImageRun run = extract_and_repair(image, 1.0);
        require_closed_and_oriented(run.surface);
        CHECK(core::region_labels(run.surface) == std::vector<core::Label>{1});
    }
    SECTION("a limit above the whole image keeps it, with a warning") {
        auto image = empty_image(5, 1.0);
        fill_box(image, {1, 1, 1}, {2, 2, 2}, 1);
        const ImageRun run = extract_and_repair(image, 100.0);
        CHECK(core::region_labels(run.surface) == std::vector<core::Label>{1});
        CHECK(any_warning(run.extract_ctx, "every component", "all are kept"));
    }
    SECTION("a surface input: repair keeps every piece when all are small") {
        core::SurfaceNetwork s = fixtures::octahedron(0.5);
        core::StageContext ctx;
        const auto out = surface::repair(s, surface::RepairParams{}, ctx);
        CHECK(out.face_count() == s.face_count());
        CHECK(any_warning(ctx, "every component", "all are kept"));
    }
}

TEST_CASE("repair names each piece it removes from a surface", "[surface]") {
    core::SurfaceNetwork s = fixtures::uv_sphere(10.0, 16);
    const core::SurfaceNetwork speck = fixtures::octahedron(0.5);
    const auto base = static_cast<std::int32_t>(s.vertex_count());
    for (std::size_t v = 0; v < speck.vertex_count(); ++v)
        s.add_vertex(speck.point(static_cast<std::int32_t>(v)) + Eigen::Vector3d(30, 0, 0));
    for (std::size_t f = 0; f < speck.face_count(); ++f)
        s.add_face(base + speck.faces[f][0], base + speck.faces[f][1], base + speck.faces[f][2], 4,
                   0);
    core::StageContext ctx;
    surface::repair(s, surface::RepairParams{}, ctx);
    REQUIRE(ctx.dropped_components().size() == 1);
    const auto& d = ctx.dropped_components()[0];
    CHECK(d.label == 4);
    CHECK(Eigen::Vector3d(d.position_mm[0], d.position_mm[1], d.position_mm[2])
              .isApprox(Eigen::Vector3d(30, 0, 0), 1e-9));
    CHECK(any_warning(ctx, "repair: label 4: component near (30, ", "not meshed"));
    // For an image, extract measured the voxels: repair removes nothing by volume.
    core::StageContext image_ctx;
    surface::RepairParams from_image;
    from_image.is_from_image = true;
    const auto kept = surface::repair(s, from_image, image_ctx);
    CHECK(kept.face_count() == s.face_count());
    CHECK(image_ctx.dropped_components().empty());
}
