#pragma once
// Repair stage, the second half of the paper's §2 background-mesh preparation ("the
// background mesh should be a water-tight triangulated surface. If not, automated and
// manual repairing routines can be applied").
//   In:  a SurfaceNetwork (from extract, or a surface file), RepairParams.
//   Out: the same network watertight: points merged, degenerate/duplicate faces and small
//        pieces removed, faces oriented out of region_in, holes filled, outer pinches
//        split, every region closed and oriented (checked), self-intersections reported.
//   Next: remesh (its background mesh).
// Implementation: surface/repair.cpp (the driver) and one repair_*.cpp per step; the file map
// is in surface/repair_internal.h.

#include <cstddef>

#include "pipeline/core/stage_context.h"
#include "pipeline/core/stage_params.h"
#include "pipeline/core/surface_network.h"

namespace frontmesh::surface {

/// Parameters of the repair stage: member `m` is recipe key `repair.m`; default, range and
/// unit are declared in repair_keys().
struct RepairParams {
    double merge_tolerance_mm = 1e-6;  ///< points closer than this are merged
    /// Components smaller are removed: for an image, extract compares the voxel volume of
    /// each connected component of a label (ExtractParams::min_component_volume_mm3); for a
    /// surface, repair compares the volume each closed piece encloses.
    double min_component_volume_mm3 = 1.0;
    std::size_t min_component_faces = 0;  ///< pieces with fewer faces are removed too
    /// Not a key: the recipe reader sets it when the input is an image. Extract then left
    /// out the small components by their voxels, and repair removes none by volume.
    bool is_from_image = false;
    std::size_t max_hole_edges = 200;  ///< larger holes are an error, not filled
    bool fill_holes = true;
    bool check_self_intersections = true;
    bool fail_on_self_intersections = true;  ///< false: warn and go on
};

/// Every `repair.*` recipe key: the member it sets, default, range, unit and a one-line
/// doc (surface/repair_params.cpp). The one declaration that validate(), the recipe reader
/// and `frontmesh keys` read; the member defaults above equal its defaults (a test checks).
const core::ParamTable<RepairParams>& repair_keys();

/// Throws InputError "repair.KEY: must be in RANGE, got VALUE" for a member outside its
/// declared range.
void validate(const RepairParams& params);

/// Merges coincident points, drops degenerate and duplicate faces, removes small
/// components (each named in a warning "repair: label L: component near (x, y, z) mm not
/// meshed: ..." and a ctx.drop() record; none when all are small), orients every face outward from
/// region_in, fills holes up to `max_hole_edges`, splits non-manifold vertices of the outer
/// boundary (pinches between a region and the outside; pinches inside the domain and junctions are
/// kept, counted), detects self-intersections, and verifies that every region's boundary is closed
/// and consistently oriented. Counts of what changed go to `ctx` counters. Throws GeometryError
/// naming the region and the place when it cannot repair.
core::SurfaceNetwork repair(const core::SurfaceNetwork& input, const RepairParams& params,
                            core::StageContext& ctx);

}  // namespace frontmesh::surface
