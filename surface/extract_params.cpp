// The extract stage's recipe keys and their check (STYLE §3: one declaration per key).

#include "surface/extract.h"

#include <cmath>
#include <string>

#include "pipeline/core/error.h"

namespace frontmesh::surface {

const core::ParamTable<ExtractParams>& extract_keys() {
    using P = ExtractParams;
    static const core::ParamTable<ExtractParams> table = {
        {"extract.method",
         {},
         "auto",
         {},
         "",
         "auto: flying_edges for one label, surface_nets for several",
         "auto, flying_edges, surface_nets"},
        {"extract.blur_sigma_mm", &P::blur_sigma_mm, "0.0", core::closed(0.0, 100.0), "mm",
         "Gaussian blur of the labels before contouring; 0 = none"},
        {"extract.smoothing_iterations", &P::smoothing_iterations, "8", core::closed(0, 1000), "",
         "surface_nets: constrained smoothing passes"},
        {"extract.smoothing_relaxation", &P::smoothing_relaxation, "0.5",
         core::above_up_to(0.0, 1.0), "", "surface_nets: step of each smoothing pass"},
        {"extract.preserve_volume",
         &P::preserve_volume,
         "true",
         {},
         "",
         "surface_nets: move each region's boundary so it encloses its voxels' volume"},
        {"extract.manifold_cleanup",
         &P::manifold_cleanup,
         "true",
         {},
         "",
         "relabel single voxels so every region boundary is a 2-manifold"},
        {"extract.closing_voxels", &P::closing_voxels, "0", core::closed(0, 10), "voxels",
         "closing radius: gaps narrower than 2 r + 1 voxels are filled; 0 = off"},
        {"extract.opening_voxels", &P::opening_voxels, "0", core::closed(0, 10), "voxels",
         "opening radius, after the closing: thinner sheets and spikes go; 0 = off"},
    };
    return table;
}

void validate(const ExtractParams& params) {
    core::check_ranges(params, extract_keys());
    for (const core::Label l : params.labels)
        if (l <= 0)
            FM_THROW(InputError, "input.labels: labels must be > 0 (0 is the outside), got " +
                                     std::to_string(l));
    if (!(std::isfinite(params.min_component_volume_mm3) && params.min_component_volume_mm3 >= 0))
        FM_THROW(InputError, "repair.min_component_volume_mm3: must be a number >= 0, got " +
                                 std::to_string(params.min_component_volume_mm3));
}

}  // namespace frontmesh::surface
