// Region volumes brought back to their voxel volumes after surface nets (issue 20, item 5);
// the method is documented at correct_region_volumes in surface/volume_correction.h.

#include "surface/volume_correction.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include "pipeline/core/self_intersection.h"
#include "surface/size_field.h"
#include "surface/surface_smoothing.h"

namespace frontmesh::surface {
namespace {

using core::Label;

// Enclosed volume per region index (faces oriented out of region_in), -1 = not a target.
std::vector<double> region_volumes(const core::SurfaceNetwork& s, const std::vector<int>& index_in,
                                   const std::vector<int>& index_out) {
    int n = 0;
    for (int i : index_in) n = std::max(n, i + 1);
    for (int i : index_out) n = std::max(n, i + 1);
    std::vector<double> volume(static_cast<std::size_t>(n), 0.0);
    // From a vertex, not the origin (core::enclosed_volume says why).
    const Eigen::Vector3d o =
        s.vertex_count() > 0 ? Eigen::Vector3d(s.point(0)) : Eigen::Vector3d::Zero();
    for (std::size_t f = 0; f < s.face_count(); ++f) {
        const auto& t = s.faces[f];
        const double v =
            (s.point(t[0]) - o).dot((s.point(t[1]) - o).cross(s.point(t[2]) - o)) / 6.0;
        if (index_in[f] >= 0) volume[static_cast<std::size_t>(index_in[f])] += v;
        if (index_out[f] >= 0) volume[static_cast<std::size_t>(index_out[f])] -= v;
    }
    return volume;
}

double worst_error(const std::vector<double>& volume, const std::vector<double>& target,
                   int& worst) {
    double e = 0.0;
    worst = -1;
    for (std::size_t r = 0; r < target.size(); ++r) {
        const double rel = std::abs(volume[r] / target[r] - 1.0);
        if (rel > e) {
            e = rel;
            worst = static_cast<int>(r);
        }
    }
    return e;
}

// Faces of what remesh and tetra cannot take from a surface: crossing pairs, region wedges
// under 1 degree (no tet fits; remesh's kUnmeshableWedgeDeg) and parts turned inside out.
std::vector<std::int32_t> defect_faces(const core::SurfaceNetwork& s) {
    std::vector<std::int32_t> faces;
    for (const auto& [f, g] : core::self_intersections(s)) faces.insert(faces.end(), {f, g});
    for (const ThinWedge& w : thin_region_wedges(s, 1.0))
        faces.insert(faces.end(), w.faces.begin(), w.faces.end());
    for (const core::InvertedPart& part : core::inverted_parts(s))
        faces.insert(faces.end(), part.faces.begin(), part.faces.end());
    return faces;
}

}  // namespace

VolumeCorrection correct_region_volumes(core::SurfaceNetwork& surface,
                                        const std::map<Label, double>& target_mm3,
                                        double max_offset_mm, int max_passes) {
    VolumeCorrection result;
    // Only regions the surface bounds: one whose voxels extract left out has nothing to move.
    std::vector<Label> present(surface.region_in.begin(), surface.region_in.end());
    present.insert(present.end(), surface.region_out.begin(), surface.region_out.end());
    std::sort(present.begin(), present.end());
    std::vector<Label> labels;
    std::vector<double> target;
    for (const auto& [label, volume] : target_mm3)
        if (volume > 0.0 && std::binary_search(present.begin(), present.end(), label)) {
            labels.push_back(label);
            target.push_back(volume);
        }
    const std::size_t nf = surface.face_count(), nv = surface.vertex_count();
    if (labels.empty() || nf == 0) return result;
    auto index_of = [&](Label l) {
        const auto it = std::lower_bound(labels.begin(), labels.end(), l);
        return it != labels.end() && *it == l ? static_cast<int>(it - labels.begin()) : -1;
    };
    std::vector<int> index_in(nf), index_out(nf);
    for (std::size_t f = 0; f < nf; ++f) {
        index_in[f] = index_of(surface.region_in[f]);
        index_out[f] = index_of(surface.region_out[f]);
    }
    const int n = static_cast<int>(labels.size());
    int worst = -1;
    std::vector<double> volume = region_volumes(surface, index_in, index_out);
    volume.resize(labels.size(), 0.0);
    result.worst_before = worst_error(volume, target, worst);
    const std::vector<double> original = surface.xyz;
    // A vertex facing another sheet across a thin gap of the outside moves at most a tenth of
    // that distance, across a thin region a quarter (both sides may move): a gap between two
    // regions (AAL's caudate and putamen) keeps four fifths of its width, which remesh needs
    // to mesh it, while a thin layer can still take back the voxels it lost.
    std::vector<double> cap(nv, max_offset_mm);
    {
        const SheetDistances d =
            sheet_distances(surface, std::vector<double>(nv, 10.0 * max_offset_mm));
        for (std::size_t v = 0; v < nv; ++v)
            cap[v] = std::min({max_offset_mm, 0.25 * d.inside[v], 0.1 * d.outside[v]});
    }

    // Each pass: one sparse SPD solve (n regions) and O(faces) work.
    for (int pass = 0; pass < max_passes && result.worst_before > 0.0; ++pass) {
        if (worst_error(volume, target, worst) <= 1e-3) break;
        ++result.passes;
        std::vector<Eigen::Triplet<double>> entries;
        Eigen::VectorXd rhs(n);
        for (int r = 0; r < n; ++r) rhs[r] = target[static_cast<std::size_t>(r)] - volume[r];
        std::vector<Eigen::Vector3d> normal(nf);  // area-weighted (twice the area)
        std::vector<double> area(nf);
        for (std::size_t f = 0; f < nf; ++f) {
            const auto& t = surface.faces[f];
            normal[f] = (surface.point(t[1]) - surface.point(t[0]))
                            .cross(surface.point(t[2]) - surface.point(t[0]));
            area[f] = 0.5 * normal[f].norm();
            const int a = index_in[f], b = index_out[f];
            // Labels not in the target (the outside, unchosen ones) keep offset 0.
            if (a >= 0) entries.emplace_back(a, a, area[f]);
            if (b >= 0) entries.emplace_back(b, b, area[f]);
            if (a >= 0 && b >= 0) {
                entries.emplace_back(a, b, -area[f]);
                entries.emplace_back(b, a, -area[f]);
            }
        }
        // A tiny diagonal keeps the matrix definite should a region reach no fixed label.
        for (int r = 0; r < n; ++r) entries.emplace_back(r, r, 1e-12);
        Eigen::SparseMatrix<double> m(n, n);
        m.setFromTriplets(entries.begin(), entries.end());
        Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(m);
        if (solver.info() != Eigen::Success) break;
        Eigen::VectorXd offset = solver.solve(rhs);
        if (solver.info() != Eigen::Success || !offset.allFinite()) break;
        for (int r = 0; r < n; ++r)
            offset[r] = std::clamp(offset[r], -max_offset_mm, max_offset_mm);

        // Vertex displacement: area-weighted mean of its faces' displacement vectors.
        std::vector<Eigen::Vector3d> move(nv, Eigen::Vector3d::Zero());
        std::vector<double> weight(nv, 0.0);
        for (std::size_t f = 0; f < nf; ++f) {
            if (!(area[f] > 0.0)) continue;
            const double oa = index_in[f] >= 0 ? offset[index_in[f]] : 0.0;
            const double ob = index_out[f] >= 0 ? offset[index_out[f]] : 0.0;
            const Eigen::Vector3d d = (oa - ob) * normal[f] / (2.0 * area[f]);
            for (std::int32_t v : surface.faces[f]) {
                move[static_cast<std::size_t>(v)] += area[f] * d;
                weight[static_cast<std::size_t>(v)] += area[f];
            }
        }
        for (std::size_t v = 0; v < nv; ++v) {
            if (!(weight[v] > 0.0)) continue;
            const auto at = static_cast<std::ptrdiff_t>(3 * v);
            const Eigen::Vector3d x0(original[std::size_t(at)], original[std::size_t(at) + 1],
                                     original[std::size_t(at) + 2]);
            Eigen::Vector3d total =
                surface.point(static_cast<std::int32_t>(v)) + move[v] / weight[v] - x0;
            if (total.norm() > cap[v]) total *= cap[v] / total.norm();
            surface.point(static_cast<std::int32_t>(v)) = x0 + total;
        }
        volume = region_volumes(surface, index_in, index_out);
        volume.resize(labels.size(), 0.0);
    }

    // Moved faces that now cross others, close a region's wedge or turn a part inside out get
    // their former vertices back (each round restores at least one vertex, or stops).
    if (result.passes > 0)
        for (;;) {
            const std::vector<std::int32_t> faces = defect_faces(surface);
            if (faces.empty()) break;
            std::size_t restored = 0;
            for (const std::int32_t face : faces)
                for (std::int32_t v : surface.faces[static_cast<std::size_t>(face)]) {
                    const auto at = static_cast<std::ptrdiff_t>(3 * static_cast<std::size_t>(v));
                    if (std::equal(original.begin() + at, original.begin() + at + 3,
                                   surface.xyz.begin() + at))
                        continue;
                    std::copy(original.begin() + at, original.begin() + at + 3,
                              surface.xyz.begin() + at);
                    ++restored;
                }
            result.vertices_put_back += restored;
            if (restored == 0) break;  // crossings the correction did not make
        }
    volume = region_volumes(surface, index_in, index_out);
    volume.resize(labels.size(), 0.0);
    result.worst_after = worst_error(volume, target, worst);
    if (worst >= 0) result.worst_region = labels[static_cast<std::size_t>(worst)];
    return result;
}

}  // namespace frontmesh::surface
