#pragma once
// Target edge length on the background surface (issue 3 item 3; DESIGN-NOTES §2): uniform,
// curvature-adaptive, thickness/gap-adaptive, per label, graded and clamped. Stored per
// background vertex, queried by position.
//
// The size h from the recipe to the front, in one direction:
//   remesh.edge_length (0: default_edge_length)  -> size_field_params()  (surface/remesh.cpp)
//   -> build_size_field(): h per background vertex (here)
//   -> RetryPolicy::size(): the rounds' multipliers (surface/remesh_retry.cpp)
//   -> the Eq. 8 analogue of the front's point placement (surface/front_step.cpp).

#include <cstdint>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/adt.h"
#include "pipeline/core/stage_context.h"
#include "pipeline/core/surface_network.h"

namespace frontmesh::surface {

struct SizeFieldParams {
    double edge_length = 0.0;          ///< h, mm, > 0 (the stage resolves 0 before)
    double gradation = 1.3;            ///< g >= 1: h(v) <= h(u) + (g - 1) |uv| along edges
    double min_edge_length = 0.0;      ///< mm; 0 = h / 4
    double max_edge_length = 0.0;      ///< mm; 0 = 4 h
    double curvature_angle_deg = 0.0;  ///< max turning angle per edge, degrees; 0 = off
    /// >= 1: a region thinner than t gets h <= t / N; 0 = off. Independently of it, two sheets
    /// closer than d always get h <= d (they must never be connected or crossed).
    int thickness_layers = 0;
    std::map<core::Label, double> label_edge_length;  ///< mm, per region label (smallest wins)
};

/// Target edge length per background vertex, interpolated linearly over faces.
class SizeField {
public:
    SizeField(const core::SurfaceNetwork& background, std::vector<double> vertex_size);

    /// Size (mm) at background vertex v.
    double at_vertex(std::int32_t v) const { return size_[std::size_t(v)]; }
    /// Size (mm) at `p` on background face `face` (barycentric interpolation of its vertex
    /// sizes); face < 0: the size of the nearest background vertex.
    double at(const Eigen::Vector3d& p, std::int32_t face) const;
    const std::vector<double>& vertex_sizes() const { return size_; }

private:
    const core::SurfaceNetwork* background_;
    std::vector<double> size_;
    core::Adt vertices_;
};

/// Counts of what limited the size.
struct SizeFieldStats {
    std::size_t curvature_limited = 0;  ///< vertices whose curvature limit is below h
    std::size_t gap_limited = 0;        ///< vertices limited by a nearby sheet or thickness
    std::size_t gap_below_min = 0;      ///< gap/thickness asked for less than the min clamp
    std::size_t graded = 0;             ///< vertices lowered by the gradation limit
};

/// Distance (mm) from each background vertex to the nearest facing sheet along its vertex
/// normal, for each (region_in, region_out) pair it touches and both sides: `inside[v]` is the
/// smallest distance through a region (thickness), `outside[v]` through the outside, label 0
/// (gap). Rays are cast up to `max_distance[v]`; infinity when no sheet is hit (a hit counts
/// when the sheet faces the ray within 60 degrees, so a concave crease is not a gap).
/// TBB-parallel, deterministic. Cost O(n) ADT box queries.
struct SheetDistances {
    std::vector<double> inside;   ///< mm, through a region
    std::vector<double> outside;  ///< mm, through the outside
};
SheetDistances sheet_distances(const core::SurfaceNetwork& background,
                               const std::vector<double>& max_distance);

/// Builds the size field: min over h, the labels' sizes, the curvature limit
/// (h <= angle * R), the sheet limits (gap d: h <= d; region thickness t: h <= t / N), then
/// the clamps, then the gradation limit (Dijkstra over background edges). Throws InputError
/// for h <= 0 or g < 1. Counters `remesh.size_*` go to ctx.
SizeField build_size_field(const core::SurfaceNetwork& background, const SizeFieldParams& params,
                           core::StageContext& ctx, SizeFieldStats* stats = nullptr);

/// Lowers `size` so that size[v] <= size[u] + (g - 1) |uv| for every edge; returns the number
/// of vertices lowered. Deterministic (Dijkstra, ties by id).
std::size_t limit_gradation(const core::SurfaceNetwork& surface, double gradation,
                            std::vector<double>& size);

/// Mean length (mm) of the surface's edges (each undirected edge once).
double mean_edge_length(const core::SurfaceNetwork& surface);

}  // namespace frontmesh::surface
