#include "pipeline/core/self_intersection.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "pipeline/core/error.h"
#include "pipeline/core/morton.h"
#include "pipeline/core/predicates.h"

namespace frontmesh::core {
namespace {

using FacePair = std::pair<std::int32_t, std::int32_t>;

// Closed axis-aligned box: the exact min/max of the coordinates, so overlap tests are exact.
// (Float boxes would halve the memory but collapse small features far from the origin, e.g.
// 1e-4 mm edges at 3e4 mm, into one overlapping cluster.)
struct Box {
    double lo[3];
    double hi[3];
};

bool boxes_overlap(const Box& a, const Box& b) {
    return a.lo[0] <= b.hi[0] && b.lo[0] <= a.hi[0] && a.lo[1] <= b.hi[1] && b.lo[1] <= a.hi[1] &&
           a.lo[2] <= b.hi[2] && b.lo[2] <= a.hi[2];
}

Box merged(const Box& a, const Box& b) {
    Box r;
    for (int k = 0; k < 3; ++k) {
        r.lo[k] = std::min(a.lo[k], b.lo[k]);
        r.hi[k] = std::max(a.hi[k], b.hi[k]);
    }
    return r;
}

// Bounding volume hierarchy over face boxes (a linear BVH). Faces are sorted along a Morton
// curve of their box centres (ties by id); a sorted range is split where its highest differing
// Morton bit changes (an octree-aligned spatial median, which keeps node boxes compact), or
// halved when all its codes are equal, down to leaves of at most 8 faces. The depth is at most
// 63 + log2(n). Node boxes are merged bottom-up; nodes are in depth-first order (a left child
// follows its parent) and keep the largest face id below them, so that a search for partners
// g > f skips whole subtrees. Leaf boxes are stored in leaf order for sequential scans.
// Memory per million faces: about 70 MB kept (leaf boxes 48 B, ids 4 B, nodes ~16 B per face),
// plus about 70 MB during the build (input boxes, sort keys, codes).
class FaceTree {
public:
    explicit FaceTree(std::vector<Box> boxes) {
        const std::size_t n = boxes.size();
        if (n == 0) return;
        double lo[3], hi[3];
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::numeric_limits<double>::infinity();
            hi[k] = -std::numeric_limits<double>::infinity();
        }
        auto centre = [&](std::size_t f, int k) {
            return 0.5 * boxes[f].lo[k] + 0.5 * boxes[f].hi[k];
        };
        for (std::size_t f = 0; f < n; ++f)
            for (int k = 0; k < 3; ++k) {
                lo[k] = std::min(lo[k], centre(f, k));
                hi[k] = std::max(hi[k], centre(f, k));
            }
        std::vector<std::pair<std::uint64_t, std::int32_t>> keys(n);
        for (std::size_t f = 0; f < n; ++f) {
            std::uint64_t code = 0;
            for (int k = 0; k < 3; ++k) {
                // Position in [0, 1] on a 2^21 grid; NaN or infinite extents (coordinates beyond
                // the float range) fall back to 0, which only affects the tree's quality.
                const double t = (centre(f, k) - lo[k]) / (hi[k] - lo[k]);
                const double clamped = t > 0.0 ? std::min(t, 1.0) : 0.0;
                const auto cell = static_cast<std::uint64_t>(clamped * 2097151.0);
                code |= morton_spread21(cell) << k;
            }
            keys[f] = {code, static_cast<std::int32_t>(f)};
        }
        std::sort(keys.begin(), keys.end());
        codes_.resize(n);
        for (std::size_t i = 0; i < n; ++i) codes_[i] = keys[i].first;
        order_.resize(n);
        leaf_boxes_.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            order_[i] = keys[i].second;
            leaf_boxes_[i] = boxes[static_cast<std::size_t>(keys[i].second)];
        }
        boxes = {};
        keys = {};
        nodes_.reserve(2 * (n / leaf_size) + 2);
        build(0, static_cast<std::int32_t>(n));
        codes_ = {};
    }

    std::size_t leaf_count() const { return leaves_.size(); }

    // Calls visit(f, g) for every face f in leaf `leaf` and face g > f whose boxes overlap. One
    // tree traversal per leaf finds the leaves near it; `near` is scratch space.
    template <class Visit>
    void for_each_pair_from_leaf(std::size_t leaf, std::vector<std::int32_t>& near,
                                 Visit&& visit) const {
        const Node& own = nodes_[static_cast<std::size_t>(leaves_[leaf])];
        std::int32_t min_id = own.max_id;
        for (std::int32_t i = own.first; i < own.first + own.count; ++i)
            min_id = std::min(min_id, order_[static_cast<std::size_t>(i)]);
        near.clear();
        std::int32_t stack[128];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const std::int32_t index = stack[--top];
            const Node& node = nodes_[static_cast<std::size_t>(index)];
            if (node.max_id <= min_id || !boxes_overlap(node.box, own.box)) continue;
            if (node.count > 0) {
                near.push_back(index);
            } else {
                stack[top++] = node.right;
                stack[top++] = index + 1;
            }
        }
        for (std::int32_t i = own.first; i < own.first + own.count; ++i) {
            const std::int32_t f = order_[static_cast<std::size_t>(i)];
            const Box& box = leaf_boxes_[static_cast<std::size_t>(i)];
            for (std::int32_t index : near) {
                const Node& other = nodes_[static_cast<std::size_t>(index)];
                for (std::int32_t j = other.first; j < other.first + other.count; ++j) {
                    const std::int32_t g = order_[static_cast<std::size_t>(j)];
                    if (g > f && boxes_overlap(leaf_boxes_[static_cast<std::size_t>(j)], box))
                        visit(f, g);
                }
            }
        }
    }

private:
    static constexpr std::int32_t leaf_size = 8;

    struct Node {
        Box box;
        std::int32_t right = -1;  // internal: index of the right child (the left is next)
        std::int32_t first = 0;   // leaf: first index into order_
        std::int32_t count = 0;   // leaf: number of faces; 0 for internal nodes
        std::int32_t max_id = -1;
    };

    std::int32_t build(std::int32_t begin, std::int32_t end) {
        const auto index = static_cast<std::int32_t>(nodes_.size());
        nodes_.emplace_back();
        Node node;
        if (end - begin <= leaf_size) {
            leaves_.push_back(index);
            node.first = begin;
            node.count = end - begin;
            node.box = leaf_boxes_[static_cast<std::size_t>(begin)];
            for (std::int32_t i = begin; i < end; ++i) {
                node.box = merged(node.box, leaf_boxes_[static_cast<std::size_t>(i)]);
                node.max_id = std::max(node.max_id, order_[static_cast<std::size_t>(i)]);
            }
        } else {
            std::int32_t mid = begin + (end - begin) / 2;
            const std::uint64_t first_code = codes_[static_cast<std::size_t>(begin)];
            const std::uint64_t last_code = codes_[static_cast<std::size_t>(end - 1)];
            if (first_code != last_code) {
                const int bit = 63 - std::countl_zero(first_code ^ last_code);
                mid = static_cast<std::int32_t>(
                    std::partition_point(codes_.begin() + begin, codes_.begin() + end,
                                         [&](std::uint64_t c) { return ((c >> bit) & 1) == 0; }) -
                    codes_.begin());
            }
            const std::int32_t left = build(begin, mid);  // == index + 1
            node.right = build(mid, end);
            const Node& l = nodes_[static_cast<std::size_t>(left)];
            const Node& r = nodes_[static_cast<std::size_t>(node.right)];
            node.box = merged(l.box, r.box);
            node.max_id = std::max(l.max_id, r.max_id);
        }
        nodes_[static_cast<std::size_t>(index)] = node;
        return index;
    }

    std::vector<std::int32_t> order_;
    std::vector<Box> leaf_boxes_;
    std::vector<Node> nodes_;
    std::vector<std::int32_t> leaves_;  // node indices of the leaves, in leaf order
    std::vector<std::uint64_t> codes_;  // sorted Morton codes, during the build only
};

// A convex piece of a face that has the shared vertex v as a vertex: a proper triangle
// (v, e0, e1), or a segment [v, e0] (e1 == e0). Its far part [e0, e1] excludes v.
struct Piece {
    const double* v;
    const double* e0;
    const double* e1;
};

// Splits face (v, x, y) into at most two pieces with apex v. A proper triangle is one piece;
// a collinear face is the segment between its extreme points, split at v; a face collapsed
// onto v yields none.
int apex_pieces(const double* v, const double* x, const double* y, bool is_degenerate,
                Piece out[2]) {
    if (!is_degenerate) {
        out[0] = {v, x, y};
        return 1;
    }
    for (int k = 0; k < 3; ++k) {
        if (v[k] == x[k] && v[k] == y[k]) continue;
        // Order along the line equals order along axis k, the line is not perpendicular to it.
        const double* lo = v;
        const double* hi = v;
        for (const double* p : {x, y}) {
            if (p[k] < lo[k]) lo = p;
            if (p[k] > hi[k]) hi = p;
        }
        int n = 0;
        if (lo != v) out[n++] = {v, lo, lo};
        if (hi != v) out[n++] = {v, hi, hi};
        return n;
    }
    return 0;
}

// Pieces P, Q with the common apex v meet outside v iff the far part of one meets the other:
// if w != v lies in both, follow the ray from v through w; it leaves P at a point of P's far
// part and Q at a point of Q's far part, and the nearer of the two lies in both.
bool pieces_meet_beyond_apex(const Piece& p, const Piece& q) {
    return segment_intersects_triangle(p.e0, p.e1, q.v, q.e0, q.e1) ||
           segment_intersects_triangle(q.e0, q.e1, p.v, p.e0, p.e1);
}

// Narrow phase for one candidate pair; see the header for the rules.
class PairTest {
public:
    PairTest(const SurfaceNetwork& surface, const std::vector<std::uint8_t>& is_degenerate)
        : surface_(surface), is_degenerate_(is_degenerate) {}

    bool operator()(std::int32_t f, std::int32_t g) const {
        const auto& a = surface_.faces[static_cast<std::size_t>(f)];
        const auto& b = surface_.faces[static_cast<std::size_t>(g)];
        std::int32_t shared[3];
        int n_shared = 0;
        for (int i = 0; i < 3; ++i) {
            const bool in_b = a[i] == b[0] || a[i] == b[1] || a[i] == b[2];
            const bool seen = std::find(shared, shared + n_shared, a[i]) != shared + n_shared;
            if (in_b && !seen) shared[n_shared++] = a[i];
        }
        switch (n_shared) {
            case 0:
                return triangles_intersect(point(a[0]), point(a[1]), point(a[2]), point(b[0]),
                                           point(b[1]), point(b[2]));
            case 1:
                return meet_beyond_vertex(f, g, shared[0]);
            case 2:
                return fold_onto_each_other(f, g, shared[0], shared[1]);
            default:  // the same vertex set: coincident faces overlap unless they have no area
                return !is_degenerate_[static_cast<std::size_t>(f)];
        }
    }

private:
    const double* point(std::int32_t v) const {
        return &surface_.xyz[3 * static_cast<std::size_t>(v)];
    }

    // The face's vertices other than `v`, repeated ids kept (they make the face degenerate).
    int others(std::int32_t face, std::int32_t v, const double* out[2]) const {
        int n = 0;
        for (std::int32_t u : surface_.faces[static_cast<std::size_t>(face)])
            if (u != v && n < 2) out[n++] = point(u);
        if (n == 1) out[n++] = out[0];
        return n;
    }

    bool meet_beyond_vertex(std::int32_t f, std::int32_t g, std::int32_t v) const {
        const double *fo[2], *go[2];
        if (others(f, v, fo) == 0 || others(g, v, go) == 0) return false;  // collapsed onto v
        Piece fp[2], gp[2];
        const int nf = apex_pieces(point(v), fo[0], fo[1], is_degenerate_[f], fp);
        const int ng = apex_pieces(point(v), go[0], go[1], is_degenerate_[g], gp);
        for (int i = 0; i < nf; ++i)
            for (int j = 0; j < ng; ++j)
                if (pieces_meet_beyond_apex(fp[i], gp[j])) return true;
        return false;
    }

    // Faces sharing edge (u, w) overlap with positive area iff their third vertices are
    // coplanar with the edge and strictly on the same side of it within that plane.
    bool fold_onto_each_other(std::int32_t f, std::int32_t g, std::int32_t u,
                              std::int32_t w) const {
        const double* x = third_vertex(f, u, w);
        const double* y = third_vertex(g, u, w);
        if (x == nullptr || y == nullptr) return false;
        const double* pu = point(u);
        const double* pw = point(w);
        // The side test first: a projection injective on the plane of (u, w, x) orders y
        // correctly if y is in that plane, and if it is not the answer is no anyway. Most
        // neighbours (e.g. the two halves of a planar quad) are rejected here without the
        // exact coplanarity test.
        for (const auto& ij : {std::array<int, 2>{0, 1}, {1, 2}, {2, 0}}) {
            const int sx = orient2d(pu, pw, x, ij[0], ij[1]);
            if (sx != 0)
                return orient2d(pu, pw, y, ij[0], ij[1]) == sx && orient3d(pu, pw, x, y) == 0;
        }
        return false;  // (u, w, x) has no area
    }

    const double* third_vertex(std::int32_t face, std::int32_t u, std::int32_t w) const {
        for (std::int32_t t : surface_.faces[static_cast<std::size_t>(face)])
            if (t != u && t != w) return point(t);
        return nullptr;
    }

    const SurfaceNetwork& surface_;
    const std::vector<std::uint8_t>& is_degenerate_;
};

void check_input(const SurfaceNetwork& surface) {
    if (surface.xyz.size() % 3 != 0)
        FM_THROW(InputError, "surface: coordinate array length " +
                                 std::to_string(surface.xyz.size()) + " is not a multiple of 3");
    for (std::size_t i = 0; i < surface.xyz.size(); ++i)
        if (!std::isfinite(surface.xyz[i]))
            FM_THROW(InputError,
                     "surface: vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
    const auto n_vertices = static_cast<std::int64_t>(surface.vertex_count());
    for (std::size_t f = 0; f < surface.face_count(); ++f)
        for (std::int32_t v : surface.faces[f])
            if (v < 0 || v >= n_vertices)
                FM_THROW(InputError, "surface: face " + std::to_string(f) + " has vertex id " +
                                         std::to_string(v) + " outside [0, " +
                                         std::to_string(n_vertices) + ")");
}

}  // namespace

std::vector<std::pair<std::int32_t, std::int32_t>> self_intersections(const SurfaceNetwork& surface,
                                                                      std::size_t max_pairs) {
    check_input(surface);
    const std::size_t n = surface.face_count();
    std::vector<FacePair> result;
    if (n < 2) return result;

    std::vector<Box> boxes(n);
    std::vector<std::uint8_t> is_degenerate(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                          for (std::size_t f = range.begin(); f != range.end(); ++f) {
                              const auto& t = surface.faces[f];
                              const double* p[3];
                              for (int i = 0; i < 3; ++i)
                                  p[i] = &surface.xyz[3 * std::size_t(t[i])];
                              for (int k = 0; k < 3; ++k) {
                                  boxes[f].lo[k] = std::min({p[0][k], p[1][k], p[2][k]});
                                  boxes[f].hi[k] = std::max({p[0][k], p[1][k], p[2][k]});
                              }
                              is_degenerate[f] = is_degenerate_triangle(p[0], p[1], p[2]);
                          }
                      });
    const FaceTree tree(std::move(boxes));
    const PairTest intersect(surface, is_degenerate);

    // Leaves are processed in parallel blocks; each block collects its pairs, the blocks are
    // concatenated in a fixed order and the result is sorted, so the output is independent of
    // the thread count. (max_pairs limits the output, not the work.)
    constexpr std::size_t block = 64;
    const std::size_t n_blocks = (tree.leaf_count() + block - 1) / block;
    std::vector<std::vector<FacePair>> found(n_blocks);
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n_blocks),
        [&](const tbb::blocked_range<std::size_t>& range) {
            std::vector<std::int32_t> near;
            for (std::size_t b = range.begin(); b != range.end(); ++b) {
                const std::size_t leaf_end = std::min(tree.leaf_count(), (b + 1) * block);
                for (std::size_t leaf = b * block; leaf < leaf_end; ++leaf)
                    tree.for_each_pair_from_leaf(leaf, near, [&](std::int32_t f, std::int32_t g) {
                        if (intersect(f, g)) found[b].emplace_back(f, g);
                    });
            }
        });
    for (const auto& pairs : found) result.insert(result.end(), pairs.begin(), pairs.end());
    std::sort(result.begin(), result.end());
    if (max_pairs > 0 && result.size() > max_pairs) result.resize(max_pairs);
    return result;
}

}  // namespace frontmesh::core
