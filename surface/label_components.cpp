#include "surface/label_components.h"

#include <limits>
#include <string>

#include "pipeline/core/error.h"

namespace frontmesh::surface {

LabelComponents label_components(const std::array<int, 3>& dims,
                                 const std::vector<core::Label>& labels) {
    const std::size_t nx = static_cast<std::size_t>(dims[0]);
    const std::size_t ny = static_cast<std::size_t>(dims[1]);
    const std::size_t nz = static_cast<std::size_t>(dims[2]);
    const std::size_t n = nx * ny * nz;
    FM_CHECK(labels.size() == n);
    if (n >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        FM_THROW(InputError, "input.image: " + std::to_string(n) +
                                 " voxels are too many to label components (at most 2^31)");
    LabelComponents out;
    out.of_voxel.assign(n, -1);
    // Breadth-first flood fill. A voxel enters the queue once, when it is given its
    // component, so the queue holds at most one component and the fills together visit
    // every voxel once and each of its six faces once: O(voxels) in all.
    std::vector<std::uint32_t> queue;
    for (std::size_t seed = 0; seed < n; ++seed) {
        if (out.of_voxel[seed] >= 0) continue;
        const auto id = static_cast<std::int32_t>(out.list.size());
        LabelComponent c;
        c.label = labels[seed];
        bool mixed = false;
        bool seen_other = false;
        auto meet = [&](core::Label other) {
            if (!seen_other) {
                c.surrounding = other;
                seen_other = true;
            } else if (other != c.surrounding) {
                mixed = true;
            }
        };
        queue.clear();
        queue.push_back(static_cast<std::uint32_t>(seed));
        out.of_voxel[seed] = id;
        for (std::size_t head = 0; head < queue.size(); ++head) {
            const std::size_t v = queue[head];
            const std::size_t i = v % nx, j = (v / nx) % ny, k = v / (nx * ny);
            ++c.voxels;
            c.centre_index += Eigen::Vector3d(double(i), double(j), double(k));
            const bool at_border[6] = {i == 0, i + 1 == nx, j == 0, j + 1 == ny, k == 0,
                                       k + 1 == nz};
            const std::size_t neighbour[6] = {v - 1, v + 1, v - nx, v + nx, v - nx * ny,
                                              v + nx * ny};
            for (int d = 0; d < 6; ++d) {
                if (at_border[d]) {
                    c.touches_border = true;
                    if (c.label != 0) meet(0);
                    continue;
                }
                const std::size_t w = neighbour[d];
                if (labels[w] != c.label) {
                    meet(labels[w]);
                } else if (out.of_voxel[w] < 0) {
                    out.of_voxel[w] = id;
                    queue.push_back(static_cast<std::uint32_t>(w));
                }
            }
        }
        c.centre_index /= double(c.voxels);
        if (mixed || !seen_other) c.surrounding = -1;
        out.list.push_back(c);
    }
    return out;
}

}  // namespace frontmesh::surface
