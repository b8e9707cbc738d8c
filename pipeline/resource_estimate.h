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

/// Peak memory per element measured with /usr/bin/time -v (maximum resident set size) on
/// examples/colin27-brain.yaml, 2 threads, divided by the stage's output count: bytes per
/// remeshed triangle, and per tet made by tetra. They cover the stage's own structures, its
/// input and output; the memory of a run is dominated by the largest stage.
inline constexpr double remesh_bytes_per_triangle = 1500.0;
inline constexpr double tetra_bytes_per_tet = 600.0;

/// Tets per (volume / h^3) in a region filled at a uniform size h (the mean edge length of
/// the surface): a regular tet of edge h has volume h^3 / (6 sqrt 2), 8.5 per h^3; measured
/// 6 on thin regions, where the front cannot grow.
inline constexpr double tets_per_h3 = 6.0;

/// Tets per surface triangle and front level: the layered front (paper §3.1) grows the size
/// by tetra.stretching alpha per level, so level k holds about 1/alpha^(2k) of the first
/// level's tets and a thick region about tets_per_layer x triangles / (1 - alpha^-2) (7 tets
/// per triangle at alpha = 1.15, as measured on colin27 and the AAL atlas).
inline constexpr double tets_per_layer = 1.7;

/// What a stage is expected to make and hold.
struct ResourceEstimate {
    std::string stage;     ///< "remesh", "tetra"
    std::string elements;  ///< "triangles", "tets"
    double count = 0.0;    ///< expected number of elements
    double h_mm = 0.0;     ///< the element size it assumes
    double memory_gib = 0.0;
    std::string basis;  ///< one phrase: what the count comes from ("area 1.2e5 mm^2, h = 1 mm")
};

/// Remesh of `background` with `params`: triangles = sum over faces of area / (sqrt(3)/4 s^2),
/// s the face's target size: remesh.edge_length (0: default_edge_length of the background),
/// lowered by remesh.label_edge_length of either side's label, within the min and max edge
/// lengths. A lower estimate where curvature or thickness adaptation refine further.
/// Cost O(faces).
ResourceEstimate remesh_estimate(const core::SurfaceNetwork& background,
                                 const surface::RemeshParams& params);

/// Remesh from a label image before extract: the area of the surface that will be meshed is
/// the area of the voxel faces between different chosen labels (labels outside `labels`, when
/// not empty, count as 0) divided by 1.5, the mean ratio of a staircase's area to the smooth
/// surface's; the default h is 1.3 voxels (twice the mean edge of a marching-cubes surface).
/// Cost O(voxels).
ResourceEstimate remesh_estimate(const core::LabelImage& image, const std::vector<core::Label>& labels,
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

/// Throws InputError "STAGE: expected about N ELEMENTS (BASIS), about M GiB of memory, more
/// than limits.max_memory_gib = L; ..." when the estimate exceeds `max_memory_gib`, naming
/// the key that raises the limit and the key that sets the element size.
void require_within_memory_limit(const ResourceEstimate& estimate, double max_memory_gib);

}  // namespace frontmesh::pipeline
