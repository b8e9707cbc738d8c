#pragma once
// Resource estimates before the stages whose work grows with the element size (issue 21,
// item 8): remesh makes about (area / h^2) triangles and tetra about (volume / h^3) tets, so
// a small remesh.edge_length asks for more memory than any machine has. The runner compares
// each estimate with limits.max_memory_gib before the stage starts; `frontmesh validate`
// does so from a surface input.

#include <string>
#include <vector>

#include "pipeline/core/label_image.h"
#include "pipeline/core/surface_network.h"
#include "surface/remesh.h"
#include "volume/tetra.h"

namespace frontmesh::pipeline {

/// Default of limits.max_memory_gib, GiB.
inline constexpr double default_max_memory_gib = 16.0;

/// Peak memory per element, measured with /usr/bin/time -v (maximum resident set size) on
/// examples/colin27-brain.yaml at remesh.edge_length 0.5 mm (2 threads): `run --from remesh
/// --until tetra` peaked at 431 MiB after remesh made 784,858 triangles and at 982 MiB after
/// tetra made 6,518,936 tets, so 576 B per triangle and 158 B per tet (rounded up below). They
/// cover the stage's own structures, its input and output; at 1.55 mm (80,620 triangles,
/// 557,572 tets) the fixed part weighs more (1,600 and 257 B), the element count little.
inline constexpr double remesh_bytes_per_triangle = 580.0;
inline constexpr double tetra_bytes_per_tet = 160.0;

/// Tets per (volume / h^3) where the front cannot grow (thin regions), h the mean edge length
/// of the surface: 4.3 measured on examples/aal-hippocampus.yaml (15,721 tets, 7,160 mm^3,
/// h = 1.25 mm); a regular tet of edge h would give 8.5.
inline constexpr double tets_per_h3 = 4.5;

/// Tets per surface triangle and front level: the layered front (paper §3.1) grows the size
/// by tetra.stretching alpha per level, so level k holds about 1/alpha^(2k) of the first
/// level's tets and a thick region about tets_per_layer x triangles / (1 - alpha^-2): 2.03 on
/// colin27 at 0.5 mm (6,518,936 tets from 784,858 triangles at alpha = 1.15), 1.69 at 1.55 mm.
inline constexpr double tets_per_layer = 2.0;

/// What a stage is expected to make and hold.
struct ResourceEstimate {
    std::string stage;     ///< "remesh", "tetra"
    std::string elements;  ///< "triangles", "tets"
    double count = 0.0;    ///< expected number of elements
    double h_mm = 0.0;     ///< the element size it assumes
    double memory_gib = 0.0;
    std::string basis;  ///< one phrase: what the count comes from ("area 1.2e5 mm^2, h = 1 mm")
    /// Refused beyond this multiple of the limit: 2 for an estimate from voxels, which
    /// overstates a surface folded at the voxel scale (colin27: 1.3e5 mm^2 from its voxels,
    /// 8.8e4 mm^2 meshed); the check on the surface itself follows before the stage.
    double slack = 1.0;
};

/// Remesh of `background` with `params`: triangles = sum over faces of area / (sqrt(3)/4 s^2),
/// s the face's target size: remesh.edge_length (0: default_edge_length of the background, at
/// most tetra.max_edge_length),
/// lowered by remesh.label_edge_length of either side's label, within the min and max edge
/// lengths. A lower estimate where curvature or thickness adaptation refine further.
/// Cost O(faces).
ResourceEstimate remesh_estimate(const core::SurfaceNetwork& background,
                                 const surface::RemeshParams& params);

/// Remesh from a label image before extract: the area of the surface that will be meshed is
/// the area of the voxel faces between different chosen labels (labels outside `labels`, when
/// not empty, count as 0) divided by 1.5, the mean ratio of a staircase's area to the smooth
/// surface's; the default h is 1.3 voxels (twice the mean edge of a marching-cubes surface).
/// Its slack is 2. Cost O(voxels).
ResourceEstimate remesh_estimate(const core::LabelImage& image,
                                 const std::vector<core::Label>& labels,
                                 const surface::RemeshParams& params);

/// Tetra on `surface` with `params`: the fewer of the uniform fill, tets_per_h3 x (volume
/// enclosed by every region) / h^3 with h the mean edge length of the surface, and the
/// layered fill, tets_per_layer x faces / (1 - alpha^-2). Cost O(faces).
ResourceEstimate tetra_estimate(const core::SurfaceNetwork& surface,
                                const volume::TetraParams& params);

/// Tetra on a surface of about `triangles` triangles of edge `h_mm` enclosing `volume_mm3`
/// (the remesh estimate before remesh has run), as above.
ResourceEstimate tetra_estimate(double volume_mm3, double triangles, double h_mm,
                                const volume::TetraParams& params);

/// Volume (mm^3) of the voxels of the chosen labels (all non-zero ones when `labels` is empty).
double labelled_volume(const core::LabelImage& image, const std::vector<core::Label>& labels);

/// Before any stage runs: throws as require_within_memory_limit for `remesh` (the remesh
/// estimate from the input), then, with `with_tetra`, for tetra on the surface remesh will
/// make (`volume_mm3` at the remesh estimate's triangles, h and slack).
void require_input_within_memory_limit(const ResourceEstimate& remesh, double volume_mm3,
                                       bool with_tetra, const volume::TetraParams& tetra,
                                       double max_memory_gib);

/// Volume (mm^3) enclosed by every region of `surface` (those turned inside out count 0).
double enclosed_volume(const core::SurfaceNetwork& surface);

/// Throws InputError "STAGE: expected about N ELEMENTS (BASIS), about M GiB of memory, more
/// than limits.max_memory_gib = L; ..." when the estimate exceeds `max_memory_gib` (times
/// its slack), naming
/// the key that raises the limit and the key that sets the element size.
void require_within_memory_limit(const ResourceEstimate& estimate, double max_memory_gib);

}  // namespace frontmesh::pipeline
