// The remesh stage's recipe keys and their check (STYLE §3: one declaration per key).

#include "surface/remesh.h"

#include <string>

#include "pipeline/core/error.h"

namespace frontmesh::surface {

const core::ParamTable<RemeshParams>& remesh_keys() {
    using P = RemeshParams;
    static const core::ParamTable<RemeshParams> table = {
        {"remesh.edge_length", &P::edge_length, "0.0", core::closed(0.0, 1e4), "mm",
         "target edge length h; 0 = twice the mean background edge length"},
        {"remesh.gradation", &P::gradation, "1.3", core::closed(1.0, 10.0), "",
         "h grows by at most (g - 1) mm per mm along the surface"},
        {"remesh.min_edge_length", &P::min_edge_length, "0.0", core::closed(0.0, 1e4), "mm",
         "smallest edge length; 0 = h / 4"},
        {"remesh.max_edge_length", &P::max_edge_length, "0.0", core::closed(0.0, 1e4), "mm",
         "largest edge length; 0 = 4 h"},
        {"remesh.curvature_angle_deg", &P::curvature_angle_deg, "0.0", core::from_below(0.0, 90.0),
         "deg", "largest turn of the normal along one edge; 0 = off"},
        {"remesh.thickness_layers", &P::thickness_layers, "0", core::closed(0, 20), "",
         "thin regions get this many edges across; 0 = off"},
        {"remesh.feature_angle_deg", &P::feature_angle_deg, "0.0", core::from_below(0.0, 180.0),
         "deg", "edges whose faces turn by more are kept as feature curves; 0 = off"},
        {"remesh.label_edge_length",
         {},
         "{}",
         core::above_up_to(0.0, 1e4),
         "mm",
         "edge length per region label, {label: size}; the smallest wins"},
        {"remesh.smoothing_iterations", &P::smoothing_iterations, "5", core::closed(0, 100), "",
         "angle-based smoothing + flip passes after the front"},
        {"remesh.flip_max_dihedral_deg", &P::flip_max_dihedral_deg, "10.0", core::closed(0.0, 90.0),
         "deg", "edges are flipped only where their faces are this flat"},
        {"remesh.max_volume_change_percent", &P::max_volume_change_percent, "0.0",
         core::closed(0.0, 100.0), "%",
         "a region changing volume by more is meshed again finer; 0 = off"},
        {"remesh.preserve_volume",
         &P::preserve_volume,
         "true",
         {},
         "",
         "move each region's faces (at most h / 10) so it keeps the background's volume"},
        {"remesh.check_self_intersections",
         &P::check_self_intersections,
         "true",
         {},
         "",
         "exact self-intersection check of the result"},
    };
    return table;
}

void validate(const RemeshParams& p) {
    core::check_ranges(p, remesh_keys());
    if (p.min_edge_length > 0.0 && p.max_edge_length > 0.0 && p.min_edge_length > p.max_edge_length)
        FM_THROW(InputError, "remesh.min_edge_length: larger than remesh.max_edge_length");
    const core::ParamRange& size =
        core::find_spec(remesh_keys(), "remesh.label_edge_length")->range;
    for (const auto& [label, mm] : p.label_edge_length)
        if (!size.contains(mm))
            FM_THROW(InputError, "remesh.label_edge_length: label " + std::to_string(label) + ": " +
                                     size.violation(mm, core::value_text(mm)));
}

}  // namespace frontmesh::surface
