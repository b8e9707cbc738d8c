// The tetra stage's recipe keys and their check (STYLE §3: one declaration per key).

#include "volume/tetra.h"

namespace frontmesh::volume {

const core::ParamTable<TetraParams>& tetra_keys() {
    using P = TetraParams;
    static const core::ParamTable<TetraParams> table = {
        {"tetra.stretching", &P::stretching, "1.15", core::above_up_to(1.0, 2.0), "",
         "alpha of Eq. 4: growth of the element size from one front level to the next"},
        {"tetra.height_smoothing_iterations", &P::height_smoothing_iterations, "3",
         core::closed(0, 100), "", "Laplacian passes over the corrected heights of Eq. 6"},
        {"tetra.max_remesh_per_node", &P::max_remesh_per_node, "3", core::closed(0, 50), "",
         "local remeshings (§3.2) per front node before its base is left for later"},
        {"tetra.min_angle_deg", &P::min_angle_deg, "5.0", core::closed(0.0, 30.0), "deg",
         "smallest face-face and edge-face angle of the step-4 tests"},
        {"tetra.max_closing_rounds", &P::max_closing_rounds, "8", core::closed(0, 100), "",
         "rounds of the closing phase for the cavities the layered front leaves"},
        {"tetra.max_edge_length", &P::max_edge_length, "0", core::closed(0.0, 1e6), "mm",
         "largest edge inside the volume (front heights capped, refine splits); 0: no cap"},
    };
    return table;
}

void validate(const TetraParams& params) { core::check_ranges(params, tetra_keys()); }

}  // namespace frontmesh::volume
