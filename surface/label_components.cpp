#include "surface/label_components.h"

#include <functional>
#include <limits>
#include <string>

#include "pipeline/core/error.h"

namespace frontmesh::surface {

namespace {

// Breadth-first flood fill of the component of `seed` (6-connectivity): `claim(w)` returns
// whether voxel w, of the seed's label, is not yet taken, and takes it. A voxel enters the
// queue once, when claimed, so the queue holds at most one component and the fill visits
// each of its voxels once and each of their six faces once.
template <class Claim>
LabelComponent flood(const std::array<int, 3>& dims, const std::vector<core::Label>& labels,
                     std::size_t seed, std::vector<std::uint32_t>& queue, Claim&& claim) {
    const std::size_t nx = static_cast<std::size_t>(dims[0]);
    const std::size_t ny = static_cast<std::size_t>(dims[1]);
    const std::size_t nz = static_cast<std::size_t>(dims[2]);
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
    claim(seed);
    for (std::size_t head = 0; head < queue.size(); ++head) {
        const std::size_t v = queue[head];
        const std::size_t i = v % nx, j = (v / nx) % ny, k = v / (nx * ny);
        ++c.voxels;
        c.centre_index += Eigen::Vector3d(double(i), double(j), double(k));
        const bool at_border[6] = {i == 0, i + 1 == nx, j == 0, j + 1 == ny, k == 0, k + 1 == nz};
        const std::size_t neighbour[6] = {v - 1, v + 1, v - nx, v + nx, v - nx * ny, v + nx * ny};
        for (int d = 0; d < 6; ++d) {
            if (at_border[d]) {
                c.touches_border = true;
                if (c.label != 0) meet(0);
                continue;
            }
            const std::size_t w = neighbour[d];
            if (labels[w] != c.label)
                meet(labels[w]);
            else if (claim(w))
                queue.push_back(static_cast<std::uint32_t>(w));
        }
    }
    c.centre_index /= double(c.voxels);
    if (mixed || !seen_other) c.surrounding = -1;
    return c;
}

void check_size(const std::array<int, 3>& dims, const std::vector<core::Label>& labels) {
    const std::size_t n = static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
                          static_cast<std::size_t>(dims[2]);
    FM_CHECK(labels.size() == n);
    if (n >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        FM_THROW(InputError, "input.image: " + std::to_string(n) +
                                 " voxels are too many to label components (at most 2^31)");
}

}  // namespace

LabelComponents label_components(const std::array<int, 3>& dims,
                                 const std::vector<core::Label>& labels) {
    check_size(dims, labels);
    const int nx = dims[0], ny = dims[1], nz = dims[2];
    const std::size_t sx = 1, sy = std::size_t(nx), sz = std::size_t(nx) * std::size_t(ny);
    LabelComponents out;
    // Scan-line union-find (cache-friendly, unlike a flood fill over the whole image): each
    // voxel is joined to its -x, -y and -z neighbours of the same label. A root is the
    // smallest voxel of its set, so every link points to a smaller voxel.
    std::vector<std::int32_t>& parent = out.of_voxel;
    parent.resize(labels.size());
    auto find = [&](std::int32_t x) {
        while (parent[std::size_t(x)] != x) {  // path halving: each step shortens the path
            parent[std::size_t(x)] = parent[std::size_t(parent[std::size_t(x)])];
            x = parent[std::size_t(x)];
        }
        return x;
    };
    auto unite = [&](std::int32_t a, std::int32_t b) {
        a = find(a);
        b = find(b);
        if (a != b) parent[std::size_t(std::max(a, b))] = std::min(a, b);
    };
    std::size_t v = 0;
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i, ++v) {
                const auto x = static_cast<std::int32_t>(v);
                parent[v] = x;
                const core::Label l = labels[v];
                if (i > 0 && labels[v - sx] == l) unite(x, x - 1);
                if (j > 0 && labels[v - sy] == l) unite(x, static_cast<std::int32_t>(v - sy));
                if (k > 0 && labels[v - sz] == l) unite(x, static_cast<std::int32_t>(v - sz));
            }
    // Component ids in order of the smallest voxel. Links point to smaller voxels, already
    // given their id in this same array, so one pass resolves every voxel.
    for (v = 0; v < labels.size(); ++v) {
        const std::int32_t p = parent[v];
        if (p == static_cast<std::int32_t>(v)) {
            parent[v] = static_cast<std::int32_t>(out.list.size());
            out.list.push_back({});
            out.list.back().label = labels[v];
        } else {
            parent[v] = parent[std::size_t(p)];
        }
    }
    // Sizes, centres, borders and the labels around each component.
    std::vector<char> seen_other(out.list.size(), 0), mixed(out.list.size(), 0);
    auto meet = [&](std::size_t c, core::Label other) {
        if (!seen_other[c]) {
            seen_other[c] = 1;
            out.list[c].surrounding = other;
        } else if (out.list[c].surrounding != other) {
            mixed[c] = 1;
        }
    };
    v = 0;
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i, ++v) {
                const auto c = static_cast<std::size_t>(parent[v]);
                LabelComponent& comp = out.list[c];
                ++comp.voxels;
                comp.centre_index += Eigen::Vector3d(double(i), double(j), double(k));
                const core::Label l = labels[v];
                if (i == 0 || j == 0 || k == 0 || i + 1 == nx || j + 1 == ny || k + 1 == nz) {
                    comp.touches_border = true;
                    if (l != 0) meet(c, 0);
                }
                const std::size_t step[3] = {sx, sy, sz};
                const bool inside[3] = {i + 1 < nx, j + 1 < ny, k + 1 < nz};
                for (int d = 0; d < 3; ++d) {
                    if (!inside[d]) continue;
                    const std::size_t w = v + step[d];
                    if (labels[w] == l) continue;
                    meet(c, labels[w]);
                    meet(static_cast<std::size_t>(parent[w]), l);
                }
            }
    for (std::size_t c = 0; c < out.list.size(); ++c) {
        LabelComponent& comp = out.list[c];
        comp.centre_index /= double(comp.voxels);
        if (mixed[c] || !seen_other[c]) comp.surrounding = -1;
    }
    return out;
}

std::vector<LabelComponent> components_containing(
    const std::array<int, 3>& dims, const std::vector<core::Label>& labels,
    const std::vector<std::size_t>& seeds,
    const std::function<void(std::size_t component, std::size_t voxel)>& visit) {
    check_size(dims, labels);
    std::vector<char> taken(labels.size(), 0);
    std::vector<std::uint32_t> queue;
    std::vector<LabelComponent> out;
    // Each voxel is claimed by at most one fill, so the fills cost at most the voxels of
    // the components they cover.
    for (const std::size_t seed : seeds) {
        if (taken[seed] || labels[seed] == 0) continue;
        const std::size_t id = out.size();
        out.push_back(flood(dims, labels, seed, queue, [&](std::size_t w) {
            if (taken[w]) return false;
            taken[w] = 1;
            visit(id, w);
            return true;
        }));
    }
    return out;
}

}  // namespace frontmesh::surface
