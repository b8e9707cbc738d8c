#include "surface/extract.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include <vtkCellArray.h>
#include <vtkDiscreteFlyingEdges3D.h>
#include <vtkFloatArray.h>
#include <vtkFlyingEdges3D.h>
#include <vtkImageData.h>
#include <vtkImageGaussianSmooth.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkUnsignedCharArray.h>

#include "pipeline/core/error.h"
#include "pipeline/core/self_intersection.h"
#include "surface/label_components.h"
#include "surface/morphology.h"
#include "surface/volume_correction.h"

namespace frontmesh::surface {
namespace {

using core::Label;

// Octant o = x + 2y + 4z of a 2x2x2 block of voxels; face neighbours differ in one bit.
constexpr std::array<std::array<int, 3>, 8> kOctant = {
    {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}}};

// True when the octants in `mask` are connected through shared faces inside the block.
bool is_face_connected(unsigned mask) {
    if (mask == 0) return true;
    unsigned seen = 1u << std::countr_zero(mask);
    for (bool grew = true; grew;) {
        grew = false;
        for (int o = 0; o < 8; ++o) {
            if (!(seen >> o & 1u)) continue;
            for (int bit = 0; bit < 3; ++bit) {
                const int n = o ^ (1 << bit);
                if ((mask >> n & 1u) && !(seen >> n & 1u)) {
                    seen |= 1u << n;
                    grew = true;
                }
            }
        }
    }
    return seen == mask;
}

const std::array<bool, 256>& connectivity_table() {
    static const std::array<bool, 256> table = [] {
        std::array<bool, 256> t{};
        for (unsigned m = 0; m < 256; ++m) t[m] = is_face_connected(m);
        return t;
    }();
    return table;
}

// The boundary of a label inside a block is a disc iff the label's octants and the rest are
// both face-connected (the link of the block's centre vertex is then a single circle).
bool is_manifold_block(unsigned mask) {
    const auto& connected = connectivity_table();
    return mask == 0 || mask == 255 || (connected[mask] && connected[~mask & 255u]);
}

struct Grid {
    std::array<int, 3> n;
    std::vector<Label>& labels;
    std::size_t index(int i, int j, int k) const {
        return (static_cast<std::size_t>(k) * n[1] + j) * n[0] + i;
    }
    bool contains(int i, int j, int k) const {
        return i >= 0 && j >= 0 && k >= 0 && i < n[0] && j < n[1] && k < n[2];
    }
    // The eight voxels of the block whose lowest corner is voxel (i, j, k), by octant.
    std::array<std::size_t, 8> block(int i, int j, int k) const {
        std::array<std::size_t, 8> at;
        for (int o = 0; o < 8; ++o)
            at[o] = index(i + kOctant[o][0], j + kOctant[o][1], k + kOctant[o][2]);
        return at;
    }
};

// The regions whose boundaries the clean-up makes 2-manifolds: every non-zero label, and
// the union of all of them against the outside (label 0), named kUnion. Without the union,
// two labels meeting the outside along one voxel edge (A, 0, B, 0 around it) or at one
// corner leave the outer boundary of the mesh non-manifold although each label is fine.
constexpr Label kUnion = 0;

unsigned region_mask(const Grid& grid, const std::array<std::size_t, 8>& at, Label region) {
    unsigned m = 0;
    for (int o = 0; o < 8; ++o) {
        const Label x = grid.labels[at[o]];
        m |= ((region == kUnion ? x != 0 : x == region) ? 1u : 0u) << o;
    }
    return m;
}

// Calls f(bi, bj, bk) for every block (given by its lowest voxel) that holds voxel (i, j, k).
template <class F>
void for_blocks_around(const Grid& grid, int i, int j, int k, F&& f) {
    for (int dk = -1; dk <= 0; ++dk)
        for (int dj = -1; dj <= 0; ++dj)
            for (int di = -1; di <= 0; ++di) {
                const int bi = i + di, bj = j + dj, bk = k + dk;
                if (bi < 0 || bj < 0 || bk < 0 || bi + 1 >= grid.n[0] || bj + 1 >= grid.n[1] ||
                    bk + 1 >= grid.n[2])
                    continue;
                f(bi, bj, bk);
            }
}

// Number of blocks holding voxel (i, j, k) in which `region` is not manifold (0 to 8).
int pinches_around(const Grid& grid, int i, int j, int k, Label region) {
    int pinches = 0;
    for_blocks_around(grid, i, j, k, [&](int bi, int bj, int bk) {
        pinches += is_manifold_block(region_mask(grid, grid.block(bi, bj, bk), region)) ? 0 : 1;
    });
    return pinches;
}

// The first region (smallest non-zero label, then the union) that is not manifold in the
// block; returns false when all are.
bool find_pinched(const Grid& grid, const std::array<std::size_t, 8>& at, Label& region,
                  unsigned& mask) {
    bool found = false;
    for (int o = 0; o < 8; ++o) {
        const Label x = grid.labels[at[o]];
        if (x == 0 || (found && x >= region)) continue;
        const unsigned m = region_mask(grid, at, x);
        if (!is_manifold_block(m)) region = x, mask = m, found = true;
    }
    if (found) return true;
    mask = region_mask(grid, at, kUnion);
    region = kUnion;
    return !is_manifold_block(mask);
}

// The non-zero label an outside voxel (octant o of the block) takes when the union grows
// over it: a label of its face neighbours in the block that stays manifold in the block,
// then the one with most such neighbours, then the smallest.
Label label_joining_union(const Grid& grid, const std::array<std::size_t, 8>& at, int o) {
    Label best = 0;
    int best_score = 1 << 30;
    for (int bit = 0; bit < 3; ++bit) {
        const Label l = grid.labels[at[o ^ (1 << bit)]];
        if (l == 0) continue;
        const unsigned m = region_mask(grid, at, l) | 1u << o;
        int own = 0;
        for (int b = 0; b < 3; ++b) own += m >> (o ^ (1 << b)) & 1u;
        const int score = (is_manifold_block(m) ? 0 : 100) - own;
        if (score < best_score || (score == best_score && l < best)) best = l, best_score = score;
    }
    return best;
}

// First phase: the region that is not manifold in a block grows there. It takes the voxel
// bridging its pieces, or the smallest piece of the rest that it encloses; when the region
// is the union, each voxel it takes from the outside gets a neighbouring label. Not bound
// to end (a growth can pinch another label), hence the pass limit and the second phase.
std::size_t make_boundaries_manifold(Grid grid, int max_passes, bool& converged) {
    std::size_t changed = 0;
    converged = false;
    const auto& connected = connectivity_table();
    for (int pass = 0; pass < max_passes; ++pass) {
        std::size_t changed_this_pass = 0;
        for (int k = 0; k + 1 < grid.n[2]; ++k)
            for (int j = 0; j + 1 < grid.n[1]; ++j)
                for (int i = 0; i + 1 < grid.n[0]; ++i) {
                    const auto at = grid.block(i, j, k);
                    const Label first = grid.labels[at[0]];
                    bool uniform = true;
                    for (int o = 1; o < 8 && uniform; ++o) uniform = grid.labels[at[o]] == first;
                    if (uniform) continue;
                    for (int attempt = 0; attempt < 16; ++attempt) {
                        Label bad = 0;
                        unsigned mask = 0;
                        if (!find_pinched(grid, at, bad, mask)) break;
                        unsigned take = 0;  // octants the region takes
                        if (!connected[mask]) {
                            // Bridge: the other octant with most neighbours in the region.
                            int best = -1, best_count = -1;
                            for (int o = 0; o < 8; ++o) {
                                if (mask >> o & 1u) continue;
                                int count = 0;
                                for (int bit = 0; bit < 3; ++bit)
                                    count += mask >> (o ^ (1 << bit)) & 1u;
                                if (count > best_count) best = o, best_count = count;
                            }
                            take = 1u << best;
                        } else {
                            // Fill the smallest face-connected piece of the rest.
                            unsigned rest = ~mask & 255u;
                            while (rest) {
                                unsigned piece = 1u << std::countr_zero(rest);
                                for (bool grew = true; grew;) {
                                    grew = false;
                                    for (int o = 0; o < 8; ++o)
                                        if (piece >> o & 1u)
                                            for (int bit = 0; bit < 3; ++bit) {
                                                const int n = o ^ (1 << bit);
                                                if ((rest >> n & 1u) && !(piece >> n & 1u))
                                                    piece |= 1u << n, grew = true;
                                            }
                                }
                                if (take == 0 || std::popcount(piece) < std::popcount(take))
                                    take = piece;
                                rest &= ~piece;
                            }
                        }
                        if (bad != kUnion) {
                            for (int o = 0; o < 8; ++o)
                                if (take >> o & 1u) grid.labels[at[o]] = bad, ++changed_this_pass;
                            continue;
                        }
                        // The union grows over outside voxels, each next to one already in it
                        // (the union is face-connected and non-empty in the block, so every
                        // piece of the rest touches it).
                        for (bool grew = true; take && grew;) {
                            grew = false;
                            for (int o = 0; o < 8; ++o) {
                                if (!(take >> o & 1u)) continue;
                                const Label l = label_joining_union(grid, at, o);
                                if (l == 0) continue;
                                grid.labels[at[o]] = l;
                                take &= ~(1u << o);
                                grew = true;
                                ++changed_this_pass;
                            }
                        }
                    }
                }
        changed += changed_this_pass;
        if (changed_this_pass == 0) {
            converged = true;
            break;
        }
    }
    return changed;
}

// Second phase, which always ends: a region not manifold in a block gives up one voxel
// there. A label gives it to a neighbouring label when that stays manifold around the voxel
// and the blocks around the voxel count fewer pinches of the two labels than before; else,
// and always for the union, the voxel goes to the outside. Each change thus lowers
// (labelled voxels, pinches of labels summed over all blocks) in lexicographic order: the
// first when a voxel goes outside, else the second with the first unchanged. Both are
// non-negative integers, so the sweeps end, and they end only when every block is manifold
// for every label and the union. Returns the number of voxels changed.
std::size_t shrink_pinches(Grid grid, std::size_t& to_outside) {
    std::size_t changed = 0;
    to_outside = 0;
    const int step[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (bool again = true; again;) {
        again = false;
        for (int k = 0; k + 1 < grid.n[2]; ++k)
            for (int j = 0; j + 1 < grid.n[1]; ++j)
                for (int i = 0; i + 1 < grid.n[0]; ++i) {
                    const auto at = grid.block(i, j, k);
                    for (int attempt = 0; attempt < 8; ++attempt) {
                        Label bad = 0;
                        unsigned mask = 0;
                        if (!find_pinched(grid, at, bad, mask)) break;
                        // The voxel of `bad` whose removal mends the block, else the one with
                        // fewest neighbours in the region.
                        int best = -1, best_score = 1 << 30;
                        for (int o = 0; o < 8; ++o) {
                            if (!(mask >> o & 1u)) continue;
                            int own = 0;
                            for (int bit = 0; bit < 3; ++bit) own += mask >> (o ^ (1 << bit)) & 1u;
                            const int score =
                                (is_manifold_block(mask & ~(1u << o)) ? 0 : 100) + own;
                            if (score < best_score) best = o, best_score = score;
                        }
                        const int vi = i + kOctant[best][0], vj = j + kOctant[best][1],
                                  vk = k + kOctant[best][2];
                        const std::size_t voxel = at[best];
                        const Label own_label = grid.labels[voxel];
                        Label target = 0;
                        if (bad != kUnion) {
                            std::map<Label, int> votes;
                            for (const auto& d : step) {
                                const int a = vi + d[0], b = vj + d[1], c = vk + d[2];
                                if (!grid.contains(a, b, c)) continue;
                                const Label l = grid.labels[grid.index(a, b, c)];
                                if (l != bad && l != 0) ++votes[l];
                            }
                            std::vector<std::pair<int, Label>> order;
                            for (const auto& [l, v] : votes) order.push_back({-v, l});
                            std::sort(order.begin(), order.end());
                            const int bad_before = pinches_around(grid, vi, vj, vk, bad);
                            for (const auto& [negative_votes, l] : order) {
                                const int l_before = pinches_around(grid, vi, vj, vk, l);
                                grid.labels[voxel] = l;
                                const bool accepted =
                                    pinches_around(grid, vi, vj, vk, l) == 0 &&
                                    pinches_around(grid, vi, vj, vk, bad) < bad_before + l_before;
                                grid.labels[voxel] = own_label;
                                if (accepted) {
                                    target = l;
                                    break;
                                }
                            }
                        }
                        grid.labels[voxel] = target;
                        to_outside += target == 0 ? 1 : 0;
                        ++changed;
                        again = true;
                    }
                }
    }
    return changed;
}

// Maps index-space points to the image's physical frame, and reports whether that map
// reverses orientation (then every face is flipped to stay outward).
struct IndexToPhysical {
    const core::LabelImage& image;
    Eigen::Vector3d operator()(const Eigen::Vector3d& index) const { return image.physical(index); }
    bool is_reflection() const {
        return (image.direction * image.spacing.asDiagonal()).determinant() < 0.0;
    }
};

// Multi-label smoothing of the label map: every label's indicator (the outside, label 0,
// included) is blurred by a Gaussian of `sigma_mm`, and each voxel takes the label whose
// blurred indicator is largest there (ties: the smaller label). Removes one-voxel fins,
// spikes and slits, whose surfaces fold too sharply for the remesher, and keeps every
// interface shared. Each label is blurred within its bounding box grown by 3 sigma, so the
// cost is about the sum of the labels' boxes. Returns the voxels changed.
std::size_t smooth_labels(const core::LabelImage& image, std::vector<Label>& labels,
                          double sigma_mm) {
    const auto& d = image.dims;
    std::array<int, 3> radius{};
    std::array<std::vector<float>, 3> kernel;
    for (int a = 0; a < 3; ++a) {
        const double sigma = sigma_mm / image.spacing[a];
        radius[std::size_t(a)] = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
        auto& k = kernel[std::size_t(a)];
        double sum = 0.0;
        for (int i = -radius[std::size_t(a)]; i <= radius[std::size_t(a)]; ++i) {
            k.push_back(static_cast<float>(std::exp(-0.5 * i * i / (sigma * sigma))));
            sum += k.back();
        }
        for (float& w : k) w = static_cast<float>(w / sum);
    }
    // Bounding boxes of the labels present.
    std::map<Label, std::array<int, 6>> boxes;
    for (int z = 0; z < d[2]; ++z)
        for (int y = 0; y < d[1]; ++y)
            for (int x = 0; x < d[0]; ++x) {
                const Label l = labels[image.index(x, y, z)];
                auto [it, fresh] = boxes.try_emplace(l, std::array<int, 6>{x, y, z, x, y, z});
                if (!fresh) {
                    auto& b = it->second;
                    b[0] = std::min(b[0], x), b[1] = std::min(b[1], y), b[2] = std::min(b[2], z);
                    b[3] = std::max(b[3], x), b[4] = std::max(b[4], y), b[5] = std::max(b[5], z);
                }
            }
    std::vector<float> best(labels.size(), -1.0f);
    std::vector<Label> arg(labels.size(), 0);
    std::vector<float> field, tmp;
    for (const auto& [label, b] : boxes) {
        int lo[3], n[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::max(0, b[std::size_t(a)] - radius[std::size_t(a)]);
            const int hi =
                std::min(d[std::size_t(a)] - 1, b[std::size_t(a) + 3] + radius[std::size_t(a)]);
            n[a] = hi - lo[a] + 1;
        }
        const std::size_t count = std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]);
        field.assign(count, 0.0f);
        auto at = [&](int x, int y, int z) {
            return (std::size_t(z) * std::size_t(n[1]) + std::size_t(y)) * std::size_t(n[0]) +
                   std::size_t(x);
        };
        for (int z = 0; z < n[2]; ++z)
            for (int y = 0; y < n[1]; ++y)
                for (int x = 0; x < n[0]; ++x)
                    field[at(x, y, z)] =
                        labels[image.index(lo[0] + x, lo[1] + y, lo[2] + z)] == label ? 1.0f : 0.0f;
        // Separable blur, one axis at a time; samples outside the image repeat the border.
        for (int a = 0; a < 3; ++a) {
            tmp.assign(count, 0.0f);
            const auto& k = kernel[std::size_t(a)];
            const int r = radius[std::size_t(a)];
            for (int z = 0; z < n[2]; ++z)
                for (int y = 0; y < n[1]; ++y)
                    for (int x = 0; x < n[0]; ++x) {
                        int c[3] = {x, y, z};
                        const int centre = c[a];
                        float sum = 0.0f;
                        for (int i = -r; i <= r; ++i) {
                            c[a] = std::clamp(centre + i, 0, n[a] - 1);
                            sum += k[std::size_t(i + r)] * field[at(c[0], c[1], c[2])];
                        }
                        tmp[at(x, y, z)] = sum;
                    }
            field.swap(tmp);
        }
        for (int z = 0; z < n[2]; ++z)
            for (int y = 0; y < n[1]; ++y)
                for (int x = 0; x < n[0]; ++x) {
                    const std::size_t v = image.index(lo[0] + x, lo[1] + y, lo[2] + z);
                    const float f = field[at(x, y, z)];
                    if (f > best[v])
                        best[v] = f, arg[v] = label;  // labels ascend: ties keep the smaller
                }
    }
    std::size_t changed = 0;
    for (std::size_t v = 0; v < labels.size(); ++v)
        if (best[v] >= 0.0f && arg[v] != labels[v]) labels[v] = arg[v], ++changed;
    return changed;
}

std::string format_number(double v) {
    std::ostringstream s;
    s << std::setprecision(6) << v;
    return s.str();
}

// `cleanup_gain`: voxels each label gained (negative: lost) in the manifold clean-up, which
// changes labels for topology's sake only; the volume correction aims at the volumes before it.
core::SurfaceNetwork surface_nets(const core::LabelImage& image, std::vector<Label>& labels,
                                  const ExtractParams& params,
                                  const std::map<Label, double>& cleanup_gain,
                                  core::StageContext& ctx) {
    const auto n = image.dims;
    Grid grid{n, labels};
    const int cx = n[0] - 1, cy = n[1] - 1, cz = n[2] - 1;
    auto cube_index = [&](int i, int j, int k) {
        return (static_cast<std::size_t>(k) * cy + j) * cx + i;
    };

    // One vertex per cube whose eight voxels do not all carry the same label.
    std::vector<std::int32_t> vertex_of_cube(static_cast<std::size_t>(cx) * cy * cz, -1);
    std::vector<Eigen::Vector3d> position;  // index space
    std::vector<std::uint8_t> label_count;  // distinct labels in the vertex's cube
    std::vector<std::array<int, 3>> cube_of_vertex;
    for (int k = 0; k < cz; ++k)
        for (int j = 0; j < cy; ++j)
            for (int i = 0; i < cx; ++i) {
                std::array<Label, 8> l;
                for (int o = 0; o < 8; ++o)
                    l[o] =
                        labels[grid.index(i + kOctant[o][0], j + kOctant[o][1], k + kOctant[o][2])];
                if (std::all_of(l.begin(), l.end(), [&](Label x) { return x == l[0]; })) continue;
                Eigen::Vector3d sum = Eigen::Vector3d::Zero();
                int crossings = 0;
                for (int o = 0; o < 8; ++o)
                    for (int bit = 0; bit < 3; ++bit) {
                        const int q = o | (1 << bit);
                        if (q == o || l[o] == l[q]) continue;
                        // Midpoint of the voxel-centre edge o-q.
                        sum += Eigen::Vector3d(i + 0.5 * (kOctant[o][0] + kOctant[q][0]),
                                               j + 0.5 * (kOctant[o][1] + kOctant[q][1]),
                                               k + 0.5 * (kOctant[o][2] + kOctant[q][2]));
                        ++crossings;
                    }
                std::array<Label, 8> sorted = l;
                std::sort(sorted.begin(), sorted.end());
                vertex_of_cube[cube_index(i, j, k)] = static_cast<std::int32_t>(position.size());
                position.push_back(sum / crossings);
                label_count.push_back(static_cast<std::uint8_t>(
                    std::unique(sorted.begin(), sorted.end()) - sorted.begin()));
                cube_of_vertex.push_back({i, j, k});
            }
    ctx.progress(0.4, "surface nets: vertices");

    // One quad per voxel face between two labels, as two triangles.
    struct Quad {
        std::array<std::int32_t, 4> v;
        Label in, out;
    };
    std::vector<Quad> quads;
    for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, w = (axis + 2) % 3;  // u x w = +axis
        for (int k = 0; k < n[2]; ++k)
            for (int j = 0; j < n[1]; ++j)
                for (int i = 0; i < n[0]; ++i) {
                    std::array<int, 3> a{i, j, k};
                    std::array<int, 3> b = a;
                    if (++b[axis] >= n[axis]) continue;
                    const Label la = labels[grid.index(a[0], a[1], a[2])];
                    const Label lb = labels[grid.index(b[0], b[1], b[2])];
                    if (la == lb) continue;
                    // The four cubes around the voxel-centre edge a-b, counter-clockwise
                    // about +axis: (u-1, w-1), (u, w-1), (u, w), (u-1, w).
                    std::array<std::int32_t, 4> v;
                    const int du[4] = {-1, 0, 0, -1}, dw[4] = {-1, -1, 0, 0};
                    for (int c = 0; c < 4; ++c) {
                        std::array<int, 3> cube = a;
                        cube[u] += du[c];
                        cube[w] += dw[c];
                        v[c] = vertex_of_cube[cube_index(cube[0], cube[1], cube[2])];
                    }
                    const Label in = std::max(la, lb), out = std::min(la, lb);
                    if (in != la) std::swap(v[1], v[3]);  // normal must point from `in` to `out`
                    quads.push_back({v, in, out});
                }
    }
    ctx.progress(0.6, "surface nets: faces");

    // Constrained smoothing: surface vertices follow all neighbours, junction-curve vertices
    // (three or more labels, two junction neighbours) follow the curve, corners stay; every
    // vertex stays inside its cube, so the topology and the shared interfaces are unchanged.
    const std::size_t nv = position.size();
    std::vector<std::pair<std::int32_t, std::int32_t>> edges;
    edges.reserve(quads.size() * 4);
    for (const Quad& q : quads)
        for (int c = 0; c < 4; ++c) {
            const auto a = q.v[c], b = q.v[(c + 1) % 4];
            edges.push_back({std::min(a, b), std::max(a, b)});
        }
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    std::vector<std::int32_t> offset(nv + 1, 0), neighbor;
    for (const auto& [a, b] : edges) {
        const bool ja = label_count[a] > 2, jb = label_count[b] > 2;
        if (!ja || jb) ++offset[a + 1];
        if (!jb || ja) ++offset[b + 1];
    }
    for (std::size_t v = 0; v < nv; ++v) offset[v + 1] += offset[v];
    neighbor.resize(offset[nv]);
    {
        std::vector<std::int32_t> fill(offset.begin(), offset.end() - 1);
        for (const auto& [a, b] : edges) {
            const bool ja = label_count[a] > 2, jb = label_count[b] > 2;
            if (!ja || jb) neighbor[fill[a]++] = b;
            if (!jb || ja) neighbor[fill[b]++] = a;
        }
    }
    const double lambda = params.smoothing_relaxation;
    constexpr double kCubeMargin = 0.1;  // voxels
    const std::vector<Eigen::Vector3d> unsmoothed = position;
    std::vector<Eigen::Vector3d> next(nv);
    for (int pass = 0; pass < params.smoothing_iterations; ++pass) {
        for (std::size_t v = 0; v < nv; ++v) {
            const int count = offset[v + 1] - offset[v];
            const bool movable = label_count[v] <= 2 ? count > 0 : count == 2;
            if (!movable) {
                next[v] = position[v];
                continue;
            }
            Eigen::Vector3d mean = Eigen::Vector3d::Zero();
            for (int e = offset[v]; e < offset[v + 1]; ++e) mean += position[neighbor[e]];
            Eigen::Vector3d p = (1.0 - lambda) * position[v] + lambda * mean / count;
            // A margin keeps the vertices of neighbouring cubes apart: clamped onto a shared
            // cube face or corner they would coincide and fold the net there.
            for (int d = 0; d < 3; ++d)
                p[d] = std::clamp(p[d], cube_of_vertex[v][d] + kCubeMargin,
                                  cube_of_vertex[v][d] + 1 - kCubeMargin);
            next[v] = p;
        }
        position.swap(next);
    }
    ctx.progress(0.8, "surface nets: smoothing");

    IndexToPhysical to_physical{image};
    core::SurfaceNetwork out;
    out.xyz.reserve(3 * nv);
    for (const auto& p : position) out.add_vertex(to_physical(p));
    const bool flip = to_physical.is_reflection();
    out.faces.reserve(2 * quads.size());
    for (const Quad& q : quads) {
        const auto p = [&](int c) { return out.point(q.v[c]); };
        std::array<std::array<std::int32_t, 3>, 2> tris;
        if ((p(0) - p(2)).squaredNorm() <= (p(1) - p(3)).squaredNorm())
            tris = {{{q.v[0], q.v[1], q.v[2]}, {q.v[0], q.v[2], q.v[3]}}};
        else
            tris = {{{q.v[0], q.v[1], q.v[3]}, {q.v[1], q.v[2], q.v[3]}}};
        for (auto t : tris) {
            if (flip) std::swap(t[1], t[2]);
            out.add_face(t[0], t[1], t[2], q.in, q.out);
        }
    }
    // Smoothing can fold faces across a thin gap or a sharp junction; the unsmoothed net
    // does not. Put the vertices of intersecting faces back until none is left: every round
    // puts back at least one vertex (two faces whose vertices are all unsmoothed do not
    // intersect), so the loop ends.
    if (params.smoothing_iterations > 0) {
        std::size_t restored = 0;
        for (;;) {
            const auto pairs = core::self_intersections(out);
            if (pairs.empty()) break;
            const std::size_t restored_before = restored;
            std::vector<std::int32_t> vertices;
            for (const auto& [f, g] : pairs)
                for (std::int32_t face : {f, g})
                    for (std::int32_t v : out.faces[static_cast<std::size_t>(face)])
                        vertices.push_back(v);
            std::sort(vertices.begin(), vertices.end());
            vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
            for (std::int32_t v : vertices) {
                const Eigen::Vector3d p = to_physical(unsmoothed[static_cast<std::size_t>(v)]);
                if (out.point(v) != p) ++restored;
                out.point(v) = p;
            }
            if (restored == restored_before) break;  // nothing left to put back
        }
        ctx.count("extract.vertices_unsmoothed", static_cast<double>(restored));
        if (restored > 0)
            ctx.info("extract: " + std::to_string(restored) +
                     " smoothed vertices put back where smoothing made faces intersect");
    }
    if (params.preserve_volume) {
        // Each region's target: the volume of its voxels before the manifold clean-up (after
        // the closing, opening and blur the user asked for, less small components dropped;
        // the clean-up moves whole voxels where a thin layer pinches). Offsets of at
        // most a quarter of the smallest voxel side keep every face within its voxel's reach
        // (a 1,000-voxel blob needs about 0.15, a tube four voxels across 0.08; a single voxel
        // would need more and keeps part of its loss rather than be bent out of shape); three
        // passes take the junctions' averaging in (1,000-voxel blobs: 7% to under 0.1%).
        std::map<Label, double> target;
        for (Label l : labels)
            if (l != 0) target[l] += 1.0;
        for (auto& [l, v] : target) {
            const auto gain = cleanup_gain.find(l);
            if (gain != cleanup_gain.end()) v = std::max(0.0, v - gain->second);
            v *= image.voxel_volume();
        }
        const VolumeCorrection c =
            correct_region_volumes(out, target, 0.25 * image.spacing.minCoeff(), 3);
        ctx.count("extract.volume_error_percent_before", 100.0 * c.worst_before);
        ctx.count("extract.volume_error_percent", 100.0 * c.worst_after);
        ctx.count("extract.volume_error_region", static_cast<double>(c.worst_region));
        ctx.count("extract.vertices_put_back_for_volume", static_cast<double>(c.vertices_put_back));
        ctx.info("extract: region volumes moved to their voxel volumes: worst error " +
                 format_number(100.0 * c.worst_before) + "% before, " +
                 format_number(100.0 * c.worst_after) + "% after (region " +
                 std::to_string(c.worst_region) + ")");
    }
    return out;
}

// Components of a chosen label and of the outside, measured in voxels (issue 20, item 5):
// the small ones are given the label around them, and every component of a chosen label
// that ends up without a surface is named.

constexpr std::size_t kWarnedComponents = 20;    // warning lines per run; the rest counted
constexpr std::size_t kListedComponents = 1000;  // ctx.drop records per run

// Names the components extract leaves out: a warning each (the first kWarnedComponents),
// a record each (the first kListedComponents), and the counters.
class ComponentLog {
public:
    ComponentLog(const core::LabelImage& image, core::StageContext& ctx)
        : image_(image), ctx_(ctx) {}

    void drop(Label label, std::size_t voxels, const Eigen::Vector3d& centre_index,
              const std::string& reason) {
        const Eigen::Vector3d p = image_.physical(centre_index);
        ++dropped_;
        dropped_voxels_ += voxels;
        if (dropped_ <= kWarnedComponents)
            ctx_.warn("extract: label " + std::to_string(label) + ": component of " +
                      std::to_string(voxels) + (voxels == 1 ? " voxel (" : " voxels (") +
                      format_number(double(voxels) * image_.voxel_volume()) + " mm^3) at (" +
                      format_number(p.x()) + ", " + format_number(p.y()) + ", " +
                      format_number(p.z()) + ") mm not meshed: " + reason);
        if (dropped_ <= kListedComponents)
            ctx_.drop({label, voxels, {p.x(), p.y(), p.z()}, reason});
    }

    void finish() {
        ctx_.count("extract.dropped_components", double(dropped_));
        ctx_.count("extract.dropped_component_voxels", double(dropped_voxels_));
        if (dropped_ > kWarnedComponents)
            ctx_.warn("extract: " + std::to_string(dropped_ - kWarnedComponents) +
                      " more components not meshed (the first " +
                      std::to_string(std::min(dropped_, kListedComponents)) +
                      " are listed in summary.json, dropped_components)");
    }

private:
    const core::LabelImage& image_;
    core::StageContext& ctx_;
    std::size_t dropped_ = 0, dropped_voxels_ = 0;
};

// Gives each component of a chosen label, and each cavity (a component of the outside off
// the image border), with fewer than `min_volume_mm3` of voxels the one label around it;
// one with several labels around it stays (it shares an interface: as repair, never tear
// one). Relabelling a component surrounded through all its faces by one label keeps every
// label's boundary manifold (no other label touches it within a 2 x 2 x 2 block, else the
// rest of that block would not have been face-connected), so this runs after the clean-up.
// Marks the relabelled voxels of chosen labels in `dropped`. When no component of a chosen
// label reaches the minimum, all are kept: the whole object is not a speck.
void drop_small_components(const core::LabelImage& image, std::vector<Label>& labels,
                           double min_volume_mm3, std::vector<char>& dropped, ComponentLog& log,
                           core::StageContext& ctx) {
    const double voxel_mm3 = image.voxel_volume();
    if (min_volume_mm3 <= voxel_mm3) return;  // no component is smaller than one voxel
    const std::string limit =
        "repair.min_component_volume_mm3 = " + format_number(min_volume_mm3) + " mm^3";
    std::size_t cavities = 0, cavity_voxels = 0, kept = 0;
    // A relabelled component merges with the label around it, so every round that changes
    // something lowers the number of components: the rounds end. A component small only
    // once its inner islands are gone is found in a later round; kRounds bounds the cost on
    // deeper nesting (what is left then is kept, as a too-large component would be).
    constexpr int kRounds = 4;
    for (int round = 0; round < kRounds; ++round) {
        const LabelComponents comps = label_components(image.dims, labels);
        const auto is_small = [&](const LabelComponent& c) {
            return double(c.voxels) * voxel_mm3 < min_volume_mm3;
        };
        if (round == 0 &&
            std::none_of(comps.list.begin(), comps.list.end(),
                         [&](const LabelComponent& c) { return c.label != 0 && !is_small(c); })) {
            ctx.warn("extract: every component of the chosen labels is smaller than " + limit +
                     "; all are kept");
            return;
        }
        std::vector<Label> to(comps.list.size(), -1);
        bool changed = false;
        for (std::size_t i = 0; i < comps.list.size(); ++i) {
            const LabelComponent& c = comps.list[i];
            if (!is_small(c)) continue;
            if (c.surrounding < 0 || (c.label == 0 && c.touches_border)) {
                kept += c.label != 0 && round == 0 ? 1 : 0;
                continue;
            }
            to[i] = c.surrounding;
            changed = true;
            if (c.label == 0) {
                ++cavities;
                cavity_voxels += c.voxels;
                continue;
            }
            log.drop(c.label, c.voxels, c.centre_index,
                     "smaller than " + limit + "; its voxels join " +
                         (c.surrounding == 0
                              ? std::string("the outside")
                              : "the region around it, " + std::to_string(c.surrounding)));
        }
        if (!changed) break;
        for (std::size_t v = 0; v < labels.size(); ++v)
            if (const Label l = to[static_cast<std::size_t>(comps.of_voxel[v])]; l >= 0) {
                if (labels[v] != 0) dropped[v] = 1;
                labels[v] = l;
            }
    }
    ctx.count("extract.filled_cavities", double(cavities));
    ctx.count("extract.filled_cavity_voxels", double(cavity_voxels));
    ctx.count("extract.small_components_kept", double(kept));
    if (cavities > 0)
        ctx.info("extract: filled " + std::to_string(cavities) + " cavities smaller than " + limit +
                 " (" + std::to_string(cavity_voxels) + " voxels)");
    if (kept > 0)
        ctx.info("extract: kept " + std::to_string(kept) + " components smaller than " + limit +
                 " that touch several labels");
}

// Names each component of a chosen label in `original` (the input image's labels, the
// others 0) that has no voxel of its label left in `labels` (what is contoured) and was
// not named as small. Only components holding a voxel whose label changed can be lost, so
// only those are filled.
void name_lost_components(const core::LabelImage& image, const std::vector<Label>& original,
                          const std::vector<Label>& labels, const std::vector<char>& dropped,
                          const std::string& cleanups, ComponentLog& log) {
    std::vector<std::size_t> changed;
    for (std::size_t v = 0; v < labels.size(); ++v)
        if (original[v] != 0 && labels[v] != original[v]) changed.push_back(v);
    if (changed.empty()) return;
    std::vector<char> survives, named;
    const std::vector<LabelComponent> comps =
        components_containing(image.dims, original, changed, [&](std::size_t c, std::size_t v) {
            if (c >= survives.size()) survives.resize(c + 1, 0), named.resize(c + 1, 0);
            if (labels[v] == original[v]) survives[c] = 1;
            if (dropped[v]) named[c] = 1;
        });
    for (std::size_t c = 0; c < comps.size(); ++c)
        if (!survives[c] && !named[c])
            log.drop(comps[c].label, comps[c].voxels, comps[c].centre_index,
                     "its voxels were removed by " + cleanups);
}

// The voxel edits that can remove a component, for messages.
std::string cleanup_names(const ExtractParams& params) {
    std::string s;
    auto add = [&](const std::string& key) { s += (s.empty() ? "" : ", ") + key; };
    if (params.closing_voxels > 0) add("extract.closing_voxels");
    if (params.opening_voxels > 0) add("extract.opening_voxels");
    if (params.blur_sigma_mm > 0) add("extract.blur_sigma_mm");
    if (params.manifold_cleanup) add("extract.manifold_cleanup");
    return s.empty() ? "the voxel clean-up" : "the voxel clean-up (" + s + ")";
}

// Discrete flying edges on `label`'s mask, or, with a blur, flying edges at 0.5 on the
// blurred mask. With a blur the small components and cavities are those of the voxels whose
// blurred value exceeds 0.5 (what the contour encloses), and `labels` becomes that mask.
core::SurfaceNetwork flying_edges(const core::LabelImage& image, std::vector<Label>& labels,
                                  Label label, const ExtractParams& params,
                                  std::vector<char>& dropped, ComponentLog& log,
                                  core::StageContext& ctx) {
    vtkNew<vtkImageData> mask;
    mask->SetDimensions(image.dims[0], image.dims[1], image.dims[2]);
    mask->SetOrigin(0.0, 0.0, 0.0);
    mask->SetSpacing(1.0, 1.0, 1.0);  // index space; the physical map is applied below
    vtkNew<vtkUnsignedCharArray> scalars;
    scalars->SetNumberOfValues(static_cast<vtkIdType>(labels.size()));
    for (std::size_t v = 0; v < labels.size(); ++v)
        scalars->SetValue(static_cast<vtkIdType>(v), labels[v] == label ? 1 : 0);
    scalars->SetName("mask");
    mask->GetPointData()->SetScalars(scalars);

    vtkSmartPointer<vtkPolyData> contour;
    if (params.blur_sigma_mm > 0.0) {
        // Blur a float copy of the mask so the 0.5 iso-level sits between inside and out.
        vtkNew<vtkImageData> as_float;
        as_float->SetDimensions(image.dims[0], image.dims[1], image.dims[2]);
        vtkNew<vtkFloatArray> values;
        values->SetNumberOfValues(scalars->GetNumberOfValues());
        for (vtkIdType v = 0; v < scalars->GetNumberOfValues(); ++v)
            values->SetValue(v, scalars->GetValue(v));
        as_float->GetPointData()->SetScalars(values);
        vtkNew<vtkImageGaussianSmooth> blur;
        blur->SetInputData(as_float);
        blur->SetDimensionality(3);
        blur->SetStandardDeviations(params.blur_sigma_mm / image.spacing.x(),
                                    params.blur_sigma_mm / image.spacing.y(),
                                    params.blur_sigma_mm / image.spacing.z());
        blur->SetRadiusFactors(3.0, 3.0, 3.0);
        blur->Update();
        vtkNew<vtkImageData> field;
        field->DeepCopy(blur->GetOutput());
        vtkDataArray* f = field->GetPointData()->GetScalars();
        FM_CHECK(f != nullptr && f->GetNumberOfTuples() == vtkIdType(labels.size()));
        // The blur renormalises its kernel at the image's faces, so a mask that reaches the
        // padding (a head cut at the neck, ch2.nii.gz) stays above 0.5 on the outermost voxel
        // layer, where flying edges leaves the surface open. That layer is the padding's
        // outside: it stays below the level and the surface closes one voxel inside.
        for (int k = 0; k < image.dims[2]; ++k)
            for (int j = 0; j < image.dims[1]; ++j)
                for (int i = 0; i < image.dims[0]; ++i)
                    if (i == 0 || j == 0 || k == 0 || i == image.dims[0] - 1 ||
                        j == image.dims[1] - 1 || k == image.dims[2] - 1)
                        f->SetTuple1(vtkIdType(image.index(i, j, k)), 0.0);
        for (std::size_t v = 0; v < labels.size(); ++v)
            labels[v] = f->GetTuple1(vtkIdType(v)) > 0.5 ? label : 0;
        const std::vector<Label> before = labels;
        drop_small_components(image, labels, params.min_component_volume_mm3, dropped, log, ctx);
        // A dropped piece goes to 0 and a filled cavity to 1: no value near it crosses 0.5.
        for (std::size_t v = 0; v < labels.size(); ++v)
            if (labels[v] != before[v]) f->SetTuple1(vtkIdType(v), labels[v] == label ? 1.0 : 0.0);
        vtkNew<vtkFlyingEdges3D> contour_filter;
        contour_filter->SetInputData(field);
        contour_filter->SetValue(0, 0.5);
        contour_filter->ComputeNormalsOff();
        contour_filter->ComputeGradientsOff();
        contour_filter->ComputeScalarsOff();
        contour_filter->Update();
        contour = contour_filter->GetOutput();
    } else {
        vtkNew<vtkDiscreteFlyingEdges3D> contour_filter;
        contour_filter->SetInputData(mask);
        contour_filter->SetValue(0, 1.0);
        contour_filter->ComputeNormalsOff();
        contour_filter->ComputeGradientsOff();
        contour_filter->ComputeScalarsOff();
        contour_filter->Update();
        contour = contour_filter->GetOutput();
    }
    ctx.progress(0.7, "flying edges: contour");

    IndexToPhysical to_physical{image};
    core::SurfaceNetwork out;
    const vtkIdType np = contour->GetNumberOfPoints();
    out.xyz.reserve(3 * static_cast<std::size_t>(np));
    for (vtkIdType p = 0; p < np; ++p) {
        double x[3];
        contour->GetPoint(p, x);
        out.add_vertex(to_physical(Eigen::Vector3d(x[0], x[1], x[2])));
    }
    vtkCellArray* polys = contour->GetPolys();
    out.faces.reserve(static_cast<std::size_t>(polys->GetNumberOfCells()));
    vtkNew<vtkIdList> ids;
    for (polys->InitTraversal(); polys->GetNextCell(ids);) {
        FM_CHECK(ids->GetNumberOfIds() == 3);
        out.add_face(static_cast<std::int32_t>(ids->GetId(0)),
                     static_cast<std::int32_t>(ids->GetId(1)),
                     static_cast<std::int32_t>(ids->GetId(2)), label, 0);
    }
    // The case table orients every triangle alike; make the enclosed volume positive.
    if (core::enclosed_volume(out, label) < 0.0)
        for (auto& t : out.faces) std::swap(t[1], t[2]);
    return out;
}

std::string label_list(const std::set<Label>& labels) {
    std::ostringstream s;
    int shown = 0;
    for (Label l : labels) {
        if (shown++ == 12) {
            s << ", ... (" << labels.size() << " in all)";
            break;
        }
        s << (shown > 1 ? ", " : "") << l;
    }
    return s.str();
}

// The non-zero labels of a label array.
std::set<Label> labels_present(const std::vector<Label>& labels) {
    std::set<Label> s;
    Label last = 0;
    for (Label l : labels)
        if (l != 0 && l != last) s.insert(last = l);
    return s;
}

// The labels to contour: the image's, after the voxel clean-up the params ask for (closing
// first, then opening, on the whole image before any label is left out). One copy of the
// label array either way; the whole image is copied only when a clean-up runs.
std::vector<Label> cleaned_labels(const core::LabelImage& image, const ExtractParams& params,
                                  core::StageContext& ctx) {
    if (params.closing_voxels <= 0 && params.opening_voxels <= 0) return image.labels;
    core::LabelImage work = image;
    if (params.closing_voxels > 0) {
        const std::size_t n = close_object(work, params.closing_voxels);
        ctx.count("extract.closing_filled_voxels", double(n));
        ctx.info("extract: closing of " + std::to_string(params.closing_voxels) +
                 " voxel(s) filled " + std::to_string(n) + " voxels");
    }
    if (params.opening_voxels > 0) {
        const std::size_t n = open_object(work, params.opening_voxels);
        ctx.count("extract.opening_removed_voxels", double(n));
        ctx.info("extract: opening of " + std::to_string(params.opening_voxels) +
                 " voxel(s) removed " + std::to_string(n) + " voxels");
    }
    return std::move(work.labels);
}

}  // namespace

std::set<Label> check_labels(const core::LabelImage& image, const std::vector<Label>& labels) {
    const std::set<Label> present = labels_present(image.labels);
    if (present.empty())
        FM_THROW(
            InputError,
            "input.image: '" + image.source +
                "' has no labelled (non-zero) voxel; for a grayscale image set input.threshold");
    std::set<Label> chosen(labels.begin(), labels.end());
    if (chosen.empty() && *present.begin() < 0) {
        // A label is positive: with input.labels: all a negative value became a region whose
        // faces had region_out -2, refused by repair naming no file or voxel (found by the
        // malformed-input campaign, issue 21). Picked labels leave it outside, as any other.
        const auto at = static_cast<std::size_t>(
            std::find_if(image.labels.begin(), image.labels.end(), [](Label l) { return l < 0; }) -
            image.labels.begin());
        const auto nx = static_cast<std::size_t>(image.dims[0]),
                   ny = static_cast<std::size_t>(image.dims[1]);
        // The reader pads the image by one voxel (label_image.h): the file's own index.
        const std::string voxel = "(" + std::to_string(at % nx - 1) + ", " +
                                  std::to_string(at / nx % ny - 1) + ", " +
                                  std::to_string(at / nx / ny - 1) + ")";
        FM_THROW(InputError, "input.image: '" + image.source + "' voxel " + voxel + " has value " +
                                 std::to_string(image.labels[at]) +
                                 ": a label is 0 (outside) or positive; pick the labels to mesh "
                                 "with input.labels, or set input.threshold to segment a "
                                 "grayscale image");
    }
    if (chosen.empty()) chosen = present;
    for (Label l : chosen)
        if (!present.count(l))
            FM_THROW(InputError, "input.labels: label " + std::to_string(l) + " is not in '" +
                                     image.source + "' (labels present: " + label_list(present) +
                                     ")");
    return chosen;
}

core::SurfaceNetwork extract(const core::LabelImage& image, const ExtractParams& params,
                             core::StageContext& ctx) {
    validate(params);
    FM_CHECK(image.labels.size() == image.voxel_count());
    const std::set<Label> present = labels_present(image.labels);
    const std::set<Label> chosen = check_labels(image, params.labels);
    ctx.count("extract.labels", static_cast<double>(chosen.size()));
    // The chosen labels as the user gave them: each of their components is meshed or named.
    std::vector<Label> only_chosen;
    if (chosen.size() != present.size()) {
        only_chosen = image.labels;
        for (Label& l : only_chosen)
            if (l != 0 && !chosen.count(l)) l = 0;
    }
    const std::vector<Label>& original = only_chosen.empty() ? image.labels : only_chosen;

    std::vector<Label> labels = cleaned_labels(image, params, ctx);
    if (chosen.size() != present.size())
        for (Label& l : labels)
            if (l != 0 && !chosen.count(l)) l = 0;

    ExtractMethod method = params.method;
    if (method == ExtractMethod::Auto)
        method = chosen.size() == 1 ? ExtractMethod::FlyingEdges : ExtractMethod::SurfaceNets;
    if (method == ExtractMethod::FlyingEdges && chosen.size() != 1)
        FM_THROW(InputError, "extract.method: flying_edges contours one label, " +
                                 std::to_string(chosen.size()) +
                                 " are chosen; use surface_nets (or auto) for several labels");

    if (method == ExtractMethod::SurfaceNets && params.blur_sigma_mm > 0.0) {
        const std::size_t changed = smooth_labels(image, labels, params.blur_sigma_mm);
        ctx.count("extract.voxels_relabelled_by_blur", static_cast<double>(changed));
        const std::set<Label> left = labels_present(labels);
        std::string lost;
        for (Label l : chosen)
            if (!left.count(l)) lost += " " + std::to_string(l);
        ctx.info("extract: label blur (sigma " + std::to_string(params.blur_sigma_mm) +
                 " mm) relabelled " + std::to_string(changed) + " voxels");
        if (!lost.empty())
            ctx.warn("extract: the label blur removed every voxel of label(s)" + lost +
                     "; lower extract.blur_sigma_mm to keep them");
    }

    std::map<Label, double> cleanup_gain;  // voxels per label, after minus before
    if (params.manifold_cleanup) {
        for (Label l : labels) cleanup_gain[l] -= 1.0;
        bool converged = false;
        std::size_t changed = make_boundaries_manifold(Grid{image.dims, labels}, 6, converged);
        if (!converged) {
            std::size_t to_outside = 0;
            const std::size_t shrunk = shrink_pinches(Grid{image.dims, labels}, to_outside);
            ctx.count("extract.voxels_given_up_for_manifold", static_cast<double>(shrunk));
            ctx.count("extract.voxels_given_to_outside_for_manifold",
                      static_cast<double>(to_outside));
            changed += shrunk;
        }
        for (Label l : labels) cleanup_gain[l] += 1.0;
        ctx.count("extract.voxels_changed_for_manifold", static_cast<double>(changed));
        if (changed > 0)
            ctx.info("extract: " + std::to_string(changed) +
                     " voxels relabelled so every region boundary and the outer boundary of"
                     " their union are manifold");
    }
    ctx.progress(0.2, "labels ready");

    ComponentLog log(image, ctx);
    std::vector<char> dropped(labels.size(), 0);  // voxels of chosen labels given away as small
    const bool blurred_mask = method == ExtractMethod::FlyingEdges && params.blur_sigma_mm > 0.0;
    if (!blurred_mask)
        drop_small_components(image, labels, params.min_component_volume_mm3, dropped, log, ctx);
    core::SurfaceNetwork out;
    if (method == ExtractMethod::FlyingEdges) {
        ctx.info("extract: VTK discrete flying edges on label " + std::to_string(*chosen.begin()) +
                 (params.blur_sigma_mm > 0
                      ? " (blur sigma " + std::to_string(params.blur_sigma_mm) + " mm)"
                      : ""));
        out = flying_edges(image, labels, *chosen.begin(), params, dropped, log, ctx);
    } else {
        ctx.info("extract: multi-label surface nets on " + std::to_string(chosen.size()) +
                 " labels");
        out = surface_nets(image, labels, params, cleanup_gain, ctx);
    }
    name_lost_components(image, original, labels, dropped, cleanup_names(params), log);
    log.finish();
    // Nothing left to mesh is the image's or the recipe's doing, not a failure of a later
    // stage (issue 21: a single labelled voxel or a label blurred away ended in an internal
    // error): name the labels and what removed them, with a place.
    if (out.face_count() == 0) {
        std::string why = " (" + cleanup_names(params) + " or the contour left no face)";
        if (!ctx.dropped_components().empty()) {
            const core::DroppedComponent& d = ctx.dropped_components().front();
            why = "; label " + std::to_string(d.label) + ": component of " +
                  std::to_string(d.voxels) + (d.voxels == 1 ? " voxel" : " voxels") + " at (" +
                  format_number(d.position_mm[0]) + ", " + format_number(d.position_mm[1]) + ", " +
                  format_number(d.position_mm[2]) + ") mm not meshed: " + d.reason;
        }
        FM_THROW(InputError, "input.image '" + image.source +
                                 "': nothing left to mesh: no surface around label(s) " +
                                 label_list(chosen) + why);
    }
    // A chosen label without a face is always named, whatever the cap on the lines above.
    const std::vector<Label> meshed = core::region_labels(out);
    for (Label l : chosen)
        if (!std::binary_search(meshed.begin(), meshed.end(), l)) {
            const auto voxels = std::count(original.begin(), original.end(), l);
            ctx.warn("extract: label " + std::to_string(l) + " is not meshed at all (" +
                     std::to_string(voxels) +
                     " voxels in the image; its components are named in"
                     " summary.json, dropped_components)");
        }
    ctx.count("extract.vertices", static_cast<double>(out.vertex_count()));
    ctx.count("extract.faces", static_cast<double>(out.face_count()));
    ctx.progress(1.0, "done");
    return out;
}

}  // namespace frontmesh::surface
