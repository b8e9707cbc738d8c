// Cuts of the remesh stage around places where a patch's front stalled twice (issue 20 item
// 2): only the background around the place keeps its triangles, not the whole patch. The
// rule is in surface/remesh_internal.h beside cut_patches().

#include <algorithm>
#include <limits>

#include "surface/remesh_internal.h"

namespace frontmesh::surface::remesh_detail {

namespace {

Eigen::Vector3d centroid(const core::SurfaceNetwork& bg, std::int32_t f) {
    const auto& t = bg.faces[std::size_t(f)];
    return (bg.point(t[0]) + bg.point(t[1]) + bg.point(t[2])) / 3.0;
}

// The faces of one patch, addressed by their position in the patch's sorted face list.
struct PatchFaces {
    const core::SurfaceNetwork& bg;
    const Features& features;
    const Patch& patch;
    std::int32_t id;

    std::size_t size() const { return patch.faces.size(); }
    std::int32_t face(std::size_t i) const { return patch.faces[i]; }
    // Position of background face f in the patch, or -1 when f lies in another patch.
    std::int64_t local(std::int32_t f) const {
        if (features.face_patch[std::size_t(f)] != id) return -1;
        return std::lower_bound(patch.faces.begin(), patch.faces.end(), f) - patch.faces.begin();
    }
    // Calls visit(j) for the patch faces j sharing an edge with patch face i.
    template <typename Visit>
    void neighbours(std::size_t i, Visit&& visit) const {
        const EdgeTable& et = features.edges;
        const std::int32_t f = face(i);
        for (int k = 0; k < 3; ++k) {
            const std::int32_t e = et.edge_of(f, k);
            for (auto s = et.face_offsets[std::size_t(e)]; s < et.face_offsets[std::size_t(e) + 1];
                 ++s) {
                const std::int32_t g = et.edge_faces[std::size_t(s)];
                if (g == f) continue;
                const std::int64_t j = local(g);
                if (j >= 0) visit(std::size_t(j));
            }
        }
    }
};

// Marks the faces whose centroid lies within `radius` of `place`, connected across edges to
// the face nearest the place.
void mark_disk(const PatchFaces& pf, const Eigen::Vector3d& place, double radius,
               std::vector<std::uint8_t>& in_part) {
    std::size_t start = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < pf.size(); ++i) {
        const double d = (centroid(pf.bg, pf.face(i)) - place).squaredNorm();
        if (d < best) {
            best = d;
            start = i;
        }
    }
    std::vector<std::size_t> stack = {start};
    in_part[start] = 1;
    while (!stack.empty()) {
        const std::size_t i = stack.back();
        stack.pop_back();
        pf.neighbours(i, [&](std::size_t j) {
            if (in_part[j] || (centroid(pf.bg, pf.face(j)) - place).norm() > radius) return;
            in_part[j] = 1;
            stack.push_back(j);
        });
    }
}

// Notches: a face outside with two or more neighbours inside joins (two passes), so that the
// part's boundary, a new curve, does not zigzag along single faces.
void fill_notches(const PatchFaces& pf, std::vector<std::uint8_t>& in_part) {
    for (int pass = 0; pass < 2; ++pass) {
        std::vector<std::size_t> add;
        for (std::size_t i = 0; i < pf.size(); ++i) {
            if (in_part[i]) continue;
            int inside = 0;
            pf.neighbours(i, [&](std::size_t j) { inside += in_part[j]; });
            if (inside >= 2) add.push_back(i);
        }
        for (const std::size_t i : add) in_part[i] = 1;
    }
}

// Pieces of the rest smaller than the part (enclosed by it, or cut off) join it; the largest
// piece always stays.
void absorb_small_pieces(const PatchFaces& pf, std::vector<std::uint8_t>& in_part) {
    const auto part_size = std::size_t(std::count(in_part.begin(), in_part.end(), 1));
    std::vector<std::int32_t> piece(pf.size(), -1);
    std::vector<std::size_t> sizes;
    for (std::size_t i0 = 0; i0 < pf.size(); ++i0) {
        if (in_part[i0] || piece[i0] >= 0) continue;
        const auto id = std::int32_t(sizes.size());
        std::size_t n = 0;
        std::vector<std::size_t> stack = {i0};
        piece[i0] = id;
        while (!stack.empty()) {
            const std::size_t i = stack.back();
            stack.pop_back();
            ++n;
            pf.neighbours(i, [&](std::size_t j) {
                if (in_part[j] || piece[j] >= 0) return;
                piece[j] = id;
                stack.push_back(j);
            });
        }
        sizes.push_back(n);
    }
    if (sizes.empty()) return;
    const auto largest = std::int32_t(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
    for (std::size_t i = 0; i < pf.size(); ++i)
        if (piece[i] >= 0 && piece[i] != largest && sizes[std::size_t(piece[i])] < part_size)
            in_part[i] = 1;
}

}  // namespace

std::int32_t cut_patches(const core::SurfaceNetwork& bg, const Features& features,
                         const SizeField& field, const std::vector<RetryPolicy::Cut>& cuts,
                         std::vector<std::int32_t>& face_part) {
    if (face_part.empty()) face_part.assign(bg.face_count(), 0);
    const std::int32_t first = *std::max_element(face_part.begin(), face_part.end()) + 1;
    std::int32_t next = first;
    for (const RetryPolicy::Cut& cut : cuts) {
        const PatchFaces pf{bg, features, features.patches[cut.patch],
                            static_cast<std::int32_t>(cut.patch)};
        std::vector<std::uint8_t> in_part(pf.size(), 0);
        for (const Eigen::Vector3d& place : cut.places)
            mark_disk(pf, place, 4.0 * field.at(place, -1), in_part);
        fill_notches(pf, in_part);
        absorb_small_pieces(pf, in_part);
        if (2 * std::size_t(std::count(in_part.begin(), in_part.end(), 1)) >= pf.size())
            std::fill(in_part.begin(), in_part.end(), 1);
        for (std::size_t i = 0; i < pf.size(); ++i)
            if (in_part[i]) face_part[std::size_t(pf.face(i))] = next;
        ++next;
    }
    return first;
}

}  // namespace frontmesh::surface::remesh_detail
