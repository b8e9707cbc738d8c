#include "surface/morphology.h"

#include <cstdint>
#include <limits>
#include <vector>

namespace frontmesh::surface {

namespace {

// Breadth-first 6-neighbour distance (in steps, capped at cap) from the voxels where
// `source` is set, through every voxel. Voxels on the image border have fewer neighbours.
std::vector<std::uint8_t> step_distance(const core::LabelImage& image,
                                        const std::vector<std::uint8_t>& source, int cap) {
    const int nx = image.dims[0], ny = image.dims[1], nz = image.dims[2];
    const std::size_t n = image.voxel_count();
    const auto far = static_cast<std::uint8_t>(cap + 1);
    std::vector<std::uint8_t> d(n, far);
    std::vector<std::size_t> front, next;
    for (std::size_t v = 0; v < n; ++v)
        if (source[v]) {
            d[v] = 0;
            front.push_back(v);
        }
    const std::size_t sx = 1, sy = std::size_t(nx), sz = std::size_t(nx) * std::size_t(ny);
    for (int step = 1; step <= cap && !front.empty(); ++step) {
        next.clear();
        for (const std::size_t v : front) {
            const int i = int(v % std::size_t(nx)), j = int(v / sy % std::size_t(ny)),
                      k = int(v / sz);
            auto visit = [&](bool inside, std::size_t w) {
                if (inside && d[w] == far) {
                    d[w] = static_cast<std::uint8_t>(step);
                    next.push_back(w);
                }
            };
            visit(i > 0, v - sx);
            visit(i + 1 < nx, v + sx);
            visit(j > 0, v - sy);
            visit(j + 1 < ny, v + sy);
            visit(k > 0, v - sz);
            visit(k + 1 < nz, v + sz);
        }
        front.swap(next);
    }
    return d;
}

}  // namespace

std::size_t open_object(core::LabelImage& image, int radius) {
    if (radius <= 0 || image.labels.empty()) return 0;
    if (radius > 100) radius = 100;
    const std::size_t n = image.voxel_count();
    // Erosion: object voxels farther than `radius` steps from the background.
    std::vector<std::uint8_t> background(n);
    for (std::size_t v = 0; v < n; ++v) background[v] = image.labels[v] == 0;
    const std::vector<std::uint8_t> to_background = step_distance(image, background, radius);
    std::vector<std::uint8_t> eroded(n);
    for (std::size_t v = 0; v < n; ++v) eroded[v] = to_background[v] > radius;
    // Dilation: object voxels within `radius` steps of the eroded set stay.
    const std::vector<std::uint8_t> to_core = step_distance(image, eroded, radius);
    std::size_t removed = 0;
    for (std::size_t v = 0; v < n; ++v)
        if (image.labels[v] != 0 && to_core[v] > radius) {
            image.labels[v] = 0;
            ++removed;
        }
    return removed;
}

std::size_t close_object(core::LabelImage& image, int radius) {
    if (radius <= 0 || image.labels.empty()) return 0;
    if (radius > 100) radius = 100;
    const std::size_t n = image.voxel_count();
    std::vector<std::uint8_t> object(n);
    for (std::size_t v = 0; v < n; ++v) object[v] = image.labels[v] != 0;
    // Dilation: background voxels within `radius` steps of the object.
    const std::vector<std::uint8_t> to_object = step_distance(image, object, radius);
    std::vector<std::uint8_t> outside(n);
    for (std::size_t v = 0; v < n; ++v) outside[v] = to_object[v] > radius;
    // Erosion of the dilated object: voxels within `radius` of what stayed outside go back.
    const std::vector<std::uint8_t> to_outside = step_distance(image, outside, radius);
    std::vector<std::size_t> filled;
    for (std::size_t v = 0; v < n; ++v)
        if (!object[v] && to_outside[v] > radius) filled.push_back(v);
    // Labels of the filled voxels: grown from the object one step at a time, smallest label
    // first among the neighbours reached in the same step (deterministic).
    const int nx = image.dims[0], ny = image.dims[1], nz = image.dims[2];
    const std::size_t sy = std::size_t(nx), sz = std::size_t(nx) * std::size_t(ny);
    std::vector<std::uint8_t> pending(n, 0);
    for (const std::size_t v : filled) pending[v] = 1;
    std::size_t left = filled.size();
    std::vector<std::pair<std::size_t, core::Label>> assign;
    while (left > 0) {
        assign.clear();
        for (const std::size_t v : filled) {
            if (!pending[v]) continue;
            const int i = int(v % sy), j = int(v / sy % std::size_t(ny)), k = int(v / sz);
            core::Label best = 0;
            auto look = [&](bool inside, std::size_t w) {
                if (!inside || pending[w]) return;
                const core::Label l = image.labels[w];
                if (l != 0 && (best == 0 || l < best)) best = l;
            };
            look(i > 0, v - 1);
            look(i + 1 < nx, v + 1);
            look(j > 0, v - sy);
            look(j + 1 < ny, v + sy);
            look(k > 0, v - sz);
            look(k + 1 < nz, v + sz);
            if (best != 0) assign.emplace_back(v, best);
        }
        if (assign.empty()) break;  // cannot happen: every filled voxel is near the object
        for (const auto& [v, l] : assign) {
            image.labels[v] = l;
            pending[v] = 0;
            --left;
        }
    }
    return filled.size() - left;
}

}  // namespace frontmesh::surface
