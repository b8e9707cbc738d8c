// Remesh of label islands of 1, 2, 4 and 8 voxels (issue 20): closed shells smaller than the
// target edge length, in the outside, inside another label and on the image border, with
// isotropic and anisotropic voxels. Each island's region must come out present, closed,
// oriented and enclosing a positive volume.

#include <array>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "pipeline/core/error.h"
#include "pipeline/core/label_image.h"
#include "pipeline/core/self_intersection.h"
#include "surface/extract.h"
#include "surface/remesh.h"
#include "surface/repair.h"

using namespace frontmesh;

namespace {

struct Island {
    std::array<int, 3> at;    // first voxel (i, j, k) of the unpadded image
    std::array<int, 3> size;  // voxels along i, j, k
    core::Label label;
};

// The islands of a 16 x 16 x 12 image (x fastest), padded by one voxel of outside as the
// image reader pads it: 1-, 2-, 4- and 8-voxel islands in the outside, a 4-voxel island on
// the image border, and a 2-voxel island inside a block of another label.
core::LabelImage island_image(const Eigen::Vector3d& spacing) {
    const std::array<int, 3> n = {16, 16, 12};
    const std::vector<Island> islands = {
        {{2, 2, 2}, {1, 1, 1}, 1},   {{7, 2, 2}, {2, 1, 1}, 2},  {{12, 2, 2}, {2, 2, 1}, 3},
        {{2, 8, 2}, {2, 2, 2}, 4},   {{0, 13, 5}, {2, 2, 1}, 5}, {{9, 9, 4}, {6, 6, 6}, 6},
        {{11, 11, 6}, {2, 1, 1}, 7}, {{3, 3, 8}, {1, 1, 1}, 8},
    };
    core::LabelImage image;
    image.dims = {n[0] + 2, n[1] + 2, n[2] + 2};
    image.spacing = spacing;
    image.origin = -spacing;
    image.labels.assign(image.voxel_count(), 0);
    for (const Island& island : islands)
        for (int k = 0; k < island.size[2]; ++k)
            for (int j = 0; j < island.size[1]; ++j)
                for (int i = 0; i < island.size[0]; ++i)
                    image.labels[image.index(island.at[0] + i + 1, island.at[1] + j + 1,
                                             island.at[2] + k + 1)] = island.label;
    image.source = "islands";
    return image;
}

}  // namespace

TEST_CASE("remesh islands of 1 to 8 voxels smaller than the edge length", "[remesh][torture]") {
    const std::vector<Eigen::Vector3d> spacings = {Eigen::Vector3d(1.0, 1.0, 1.0),
                                                   Eigen::Vector3d(0.9, 0.9, 1.1)};
    for (const Eigen::Vector3d& spacing : spacings) {
        for (const double h : {1.2, 1.6, 2.0}) {
            INFO("voxels " << spacing.transpose() << " mm, h " << h << " mm");
            core::StageContext ctx;
            surface::ExtractParams ep;
            ep.min_component_volume_mm3 = 0.0;  // keep every island
            surface::RepairParams rp;
            rp.min_component_volume_mm3 = 0.0;
            const core::SurfaceNetwork bg =
                surface::repair(surface::extract(island_image(spacing), ep, ctx), rp, ctx);
            const std::vector<core::Label> labels = core::region_labels(bg);
            REQUIRE(labels.size() == 8);
            surface::RemeshParams params;
            params.edge_length = h;
            const surface::RemeshResult r = surface::remesh(bg, params, ctx);
            CHECK(core::region_labels(r.surface) == labels);
            for (const auto& c : core::check_region_boundaries(r.surface)) {
                INFO("region " << c.region);
                CHECK(c.is_closed());
                CHECK(c.is_oriented());
                CHECK(c.nonmanifold_edges == 0);
                CHECK(c.volume > 0.0);
            }
            CHECK(core::self_intersections(r.surface, 1).empty());
            // Shells smaller than h are meshed whole at once, none left to the last resort.
            const auto& counters = ctx.counters();
            const auto counter = [&counters](const std::string& name) {
                const auto it = counters.find(name);
                return it == counters.end() ? 0.0 : it->second;
            };
            CHECK(counter("remesh.patches_coarse") >= 1.0);
            CHECK(counter("remesh.patches_copied_from_background") == 0.0);
        }
    }
}
