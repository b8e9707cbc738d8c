#include "pipeline/resource_estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "pipeline/core/error.h"
#include "surface/size_field.h"

namespace frontmesh::pipeline {
namespace {

constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;
// Area of an equilateral triangle of edge 1, and of a staircase over a smooth surface (the
// mean of |n_x| + |n_y| + |n_z| over all directions: Cauchy-Crofton).
const double kTriangleArea = std::sqrt(3.0) / 4.0;
constexpr double kStaircaseRatio = 1.5;

std::string number(double value) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", value);
    return buf;
}

// The target size of a face between labels a and b: h, lowered by either label's
// remesh.label_edge_length.
double face_size(const surface::RemeshParams& params, double h, core::Label a, core::Label b) {
    double s = h;
    for (const core::Label l : {a, b})
        if (const auto it = params.label_edge_length.find(l); it != params.label_edge_length.end())
            s = std::min(s, it->second);
    return s;
}

// The label a voxel takes for meshing: 0 unless chosen.
core::Label chosen(core::Label l, const std::vector<core::Label>& labels) {
    return labels.empty() || std::binary_search(labels.begin(), labels.end(), l) ? l : 0;
}

ResourceEstimate remesh_result(double triangles, double h, const std::string& basis) {
    return {"remesh", "triangles", triangles, h, triangles * remesh_bytes_per_triangle / kGiB,
            basis};
}

}  // namespace

ResourceEstimate remesh_estimate(const core::SurfaceNetwork& background,
                                 const surface::RemeshParams& params) {
    const double h = surface::resolved_edge_length(params, background);
    double area = 0.0, triangles = 0.0;
    for (std::size_t f = 0; f < background.face_count(); ++f) {  // one pass over the faces
        const auto& t = background.faces[f];
        const double a = 0.5 * (background.point(t[1]) - background.point(t[0]))
                                   .cross(background.point(t[2]) - background.point(t[0]))
                                   .norm();
        const double s = face_size(params, h, background.region_in[f], background.region_out[f]);
        area += a;
        triangles += a / (kTriangleArea * s * s);
    }
    return remesh_result(triangles, h,
                         "surface area " + number(area) + " mm^2 at h = " + number(h) + " mm");
}

ResourceEstimate remesh_estimate(const core::LabelImage& image,
                                 const std::vector<core::Label>& labels,
                                 const surface::RemeshParams& params) {
    double h =
        params.edge_length > 0.0 ? params.edge_length : 1.3 * std::cbrt(image.voxel_volume());
    if (params.edge_length == 0.0 && params.volume_edge_cap > 0.0)
        h = std::min(h, params.volume_edge_cap);  // as resolved_edge_length
    const Eigen::Vector3d& sp = image.spacing;
    const double face_area[3] = {sp.y() * sp.z(), sp.x() * sp.z(), sp.x() * sp.y()};
    // Voxel faces per label pair: the size is looked up once per pair, not per face.
    std::map<std::pair<core::Label, core::Label>, double> pair_area;
    for (int axis = 0; axis < 3; ++axis) {
        const int di = axis == 0, dj = axis == 1, dk = axis == 2;
        for (int k = 0; k + dk < image.dims[2]; ++k)  // one pass over the voxels per axis
            for (int j = 0; j + dj < image.dims[1]; ++j)
                for (int i = 0; i + di < image.dims[0]; ++i) {
                    const core::Label a = chosen(image.at(i, j, k), labels);
                    const core::Label b = chosen(image.at(i + di, j + dj, k + dk), labels);
                    if (a != b) pair_area[{std::min(a, b), std::max(a, b)}] += face_area[axis];
                }
    }
    double area = 0.0, triangles = 0.0;
    for (const auto& [pair, staircase] : pair_area) {
        const double s = face_size(params, h, pair.first, pair.second);
        area += staircase / kStaircaseRatio;
        triangles += staircase / kStaircaseRatio / (kTriangleArea * s * s);
    }
    ResourceEstimate e = remesh_result(
        triangles, h, "surface area about " + number(area) + " mm^2 at h = " + number(h) + " mm");
    e.slack = 2.0;
    return e;
}

double enclosed_volume(const core::SurfaceNetwork& surface) {
    double volume = 0.0;
    for (const core::Label region : core::region_labels(surface))
        volume += std::max(core::enclosed_volume(surface, region), 0.0);
    return volume;
}

void require_input_within_memory_limit(const ResourceEstimate& remesh, double volume_mm3,
                                       bool with_tetra, const volume::TetraParams& tetra,
                                       double max_memory_gib) {
    require_within_memory_limit(remesh, max_memory_gib);
    if (!with_tetra) return;
    ResourceEstimate tets = tetra_estimate(volume_mm3, remesh.count, remesh.h_mm, tetra);
    tets.slack = remesh.slack;
    require_within_memory_limit(tets, max_memory_gib);
}

ResourceEstimate tetra_estimate(const core::SurfaceNetwork& surface,
                                const volume::TetraParams& params) {
    return tetra_estimate(enclosed_volume(surface), static_cast<double>(surface.face_count()),
                          surface::mean_edge_length(surface), params);
}

ResourceEstimate tetra_estimate(double volume_mm3, double triangles, double h_mm,
                                const volume::TetraParams& params) {
    const double uniform = tets_per_h3 * volume_mm3 / (h_mm * h_mm * h_mm);
    const double alpha = params.stretching;
    const double layered = tets_per_layer * triangles / (1.0 - 1.0 / (alpha * alpha));
    const double tets = std::min(uniform, layered);
    return {"tetra",
            "tets",
            tets,
            h_mm,
            tets * tetra_bytes_per_tet / kGiB,
            "volume " + number(volume_mm3) + " mm^3, " + number(triangles) +
                " surface triangles at h = " + number(h_mm) + " mm, tetra.stretching " +
                number(alpha)};
}

double labelled_volume(const core::LabelImage& image, const std::vector<core::Label>& labels) {
    std::size_t voxels = 0;
    for (const core::Label l : image.labels) voxels += chosen(l, labels) != 0 ? 1 : 0;
    return static_cast<double>(voxels) * image.voxel_volume();
}

void require_within_memory_limit(const ResourceEstimate& estimate, double max_memory_gib) {
    if (estimate.memory_gib <= estimate.slack * max_memory_gib) return;
    std::ostringstream limit;  // as a recipe gives it: 16, 65536, 1e-07
    limit << max_memory_gib;
    FM_THROW(InputError,
             estimate.stage + ": expected about " + number(estimate.count) + " " +
                 estimate.elements + " (" + estimate.basis + "), about " +
                 number(estimate.memory_gib) +
                 " GiB of memory, more than limits.max_memory_gib = " + limit.str() +
                 " GiB; choose a larger remesh.edge_length (or remesh.label_edge_length), or "
                 "raise limits.max_memory_gib on a machine with more memory");
}

}  // namespace frontmesh::pipeline
