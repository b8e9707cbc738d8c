// The repair stage's recipe keys and their check (STYLE §3: one declaration per key).

#include "surface/repair.h"

namespace frontmesh::surface {

const core::ParamTable<RepairParams>& repair_keys() {
    using P = RepairParams;
    static const core::ParamTable<RepairParams> table = {
        {"repair.merge_tolerance_mm", &P::merge_tolerance_mm, "1.0e-6", core::closed(0.0, 1.0),
         "mm", "points closer than this are merged"},
        {"repair.min_component_volume_mm3", &P::min_component_volume_mm3, "1.0",
         core::closed(0.0, 1e12), "mm^3",
         "components with fewer mm^3 of voxels (image; decided by extract) or enclosing less "
         "(surface) are removed"},
        {"repair.min_component_faces", &P::min_component_faces, "0", core::closed(0, 1e9), "faces",
         "pieces with fewer faces are removed too; 0 = no limit"},
        // Filling is cubic in the hole size: at most 2000 edges.
        {"repair.max_hole_edges", &P::max_hole_edges, "200", core::closed(3, 2000), "edges",
         "holes up to this size are filled, a larger one is an error"},
        {"repair.fill_holes",
         &P::fill_holes,
         "true",
         {},
         "",
         "fill holes (true) or report them as an error (false)"},
        {"repair.check_self_intersections",
         &P::check_self_intersections,
         "true",
         {},
         "",
         "look for self-intersecting faces"},
        {"repair.fail_on_self_intersections",
         &P::fail_on_self_intersections,
         "true",
         {},
         "",
         "a self-intersection stops the run (true) or is a warning (false)"},
    };
    return table;
}

void validate(const RepairParams& params) { core::check_ranges(params, repair_keys()); }

}  // namespace frontmesh::surface
