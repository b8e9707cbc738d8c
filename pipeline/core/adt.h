#pragma once
// Alternating digital tree (J. Bonet and J. Peraire, IJNME 31, 1991): the one geometric
// search structure of frontmesh (STYLE §2), used by remesh (background faces) and tetra
// (front nodes, paper §3.1.3-3.1.4).
//
// An item is a closed axis-aligned box (a point is a box with lo == hi). Every tree node holds
// exactly one item and bisects its region of key space in one key coordinate, x, y, z
// alternating with the depth; an item's key is the low corner of its box. Queries prune with
// a bounding box stored per node, the union of the item boxes in its subtree, so a subtree
// whose items all miss the query region is skipped whole. Bonet and Peraire key a box by the
// 6-D point (x_min, y_min, z_min, x_max, y_max, z_max), whose key-space regions bound the boxes
// for pruning; the stored subtree bounds do that here, more tightly, and 3-D keys keep the tree
// as shallow as a tree of points (depth 25 instead of 42 for 1M small boxes): about 25% faster
// box queries (tests/bench/bench_adt) and about 7% less tetra time on the Colin27 brain.
//
// The root region is a fixed domain given at construction. Items outside it are allowed:
// their key is clamped to the domain to choose a branch, the exact box is kept for the tests,
// and queries treat a region bound that lies on the domain boundary as unbounded.

#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/huge_pages.h"

namespace frontmesh::core {

/// Closed axis-aligned box; a point is a box with lo == hi. Coordinates in mm.
struct AdtBox {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());

    /// The degenerate box holding only `p`.
    static AdtBox of_point(const Eigen::Vector3d& p) { return {p, p}; }

    /// Grows the box to contain `p`. A default-constructed box is empty and grows from `p`.
    void extend(const Eigen::Vector3d& p) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }

    /// The box grown by `margin` (mm, >= 0) on every side.
    AdtBox enlarged(double margin) const {
        return {(lo.array() - margin).matrix(), (hi.array() + margin).matrix()};
    }

    /// True when every coordinate is finite and lo <= hi on every axis.
    bool is_valid() const {
        return lo.allFinite() && hi.allFinite() && (lo.array() <= hi.array()).all();
    }
};

/// True when the closed boxes share at least one point.
inline bool boxes_intersect(const AdtBox& a, const AdtBox& b) {
    return (a.lo.array() <= b.hi.array()).all() && (a.hi.array() >= b.lo.array()).all();
}

/// Squared Euclidean distance (mm^2) from `p` to the closed box `box`; 0 inside. Computed as
/// the sum over x, y, z of max(lo - p, p - hi, 0)^2, the rule every ADT query uses.
inline double squared_distance(const AdtBox& box, const Eigen::Vector3d& p) {
    double d2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        double d = 0.0;
        if (box.lo[a] - p[a] > d) d = box.lo[a] - p[a];
        if (p[a] - box.hi[a] > d) d = p[a] - box.hi[a];
        d2 += d * d;
    }
    return d2;
}

/// What an Adt stores: points, or boxes (a point tree checks that every box is a point).
enum class AdtItems { points, boxes };

/// Order of query results: increasing id, or the order of the tree walk, which depends only
/// on the sequence of insertions and removals (deterministic) and saves the sort, for callers
/// to whom the order does not matter (about 4% of the tetra stage).
enum class AdtOrder { by_id, walk };

/// An item found by a nearest-item query.
struct AdtNeighbor {
    std::int32_t id = -1;                                        ///< -1 when the tree is empty
    double distance2 = std::numeric_limits<double>::infinity();  ///< squared distance, mm^2
};

/// Alternating digital tree over caller-given int32 ids (vertex, face or other ids; the
/// tree is agnostic to their kind), with insertion, O(depth) removal and box, sphere and
/// nearest queries.
///
/// Memory: one 88-byte node per live item (6 doubles, the subtree bounds as 6 floats, id,
/// parent and two children as int32) plus a 4-byte id->node entry per id value up to the
/// largest id: about 92 MB per million items with dense ids (vector growth may add up to 2x
/// unless `reserve` is used). Removed nodes go to a free list and are reused, so the pool
/// never exceeds the largest number of items alive at once. Ids index the id->node table
/// directly: keep them dense.
///
/// Depth is O(log n) for spread-out items; k items with identical keys form a chain of
/// length k (a property of the ADT), so queries near them cost O(k). Traversals are
/// iterative, with a per-thread stack of at most one node index (16 B for nearest) per
/// level. Subtree bounds are widened on insert and kept on remove: they stay conservative
/// (never smaller than the items below; within the node's key-space region up to float
/// rounding) but may be looser than exact until `compact`, which recomputes them. Nodes live
/// in insertion order; `compact` reorders them depth-first, which speeds up queries on trees
/// larger than the caches.
///
/// Thread safety: const member functions may run concurrently with each other (each thread
/// uses its own traversal stack); any mutation needs exclusive access.
class Adt {
public:
    /// An empty tree whose root region is `domain` (e.g. the input's bounding box slightly
    /// enlarged). Throws InputError when `domain` is not finite or lo > hi on some axis.
    /// A zero extent on an axis is allowed but gives that axis no separating power.
    Adt(const AdtBox& domain, AdtItems items);

    /// Inserts the point `p` under `id`. Valid for both kinds (a point is a degenerate box).
    /// Preconditions: id >= 0 and not present (else InternalError); throws InputError when
    /// `p` is not finite. Cost O(depth).
    void insert(std::int32_t id, const Eigen::Vector3d& p);

    /// Inserts the box `box` under `id`. A tree of points accepts only degenerate boxes.
    /// Preconditions: id >= 0 and not present, and (points tree) box.lo == box.hi, else
    /// InternalError; throws InputError when `box` is not valid. Cost O(depth).
    void insert(std::int32_t id, const AdtBox& box);

    /// Removes `id`; false when it is not present. The node takes over the item of a leaf
    /// below it and the leaf goes to the free list. Cost O(depth).
    bool remove(std::int32_t id);

    /// True when `id` is present.
    bool contains(std::int32_t id) const {
        return id >= 0 && id < static_cast<std::int32_t>(node_of_id_.size()) &&
               node_of_id_[static_cast<std::size_t>(id)] >= 0;
    }

    /// The stored box of `id`. Precondition: contains(id) (else InternalError).
    AdtBox box(std::int32_t id) const;

    /// Number of items present.
    std::int32_t size() const { return size_; }

    /// True when no item is present.
    bool is_empty() const { return size_ == 0; }

    /// Removes every item; keeps the allocated capacity.
    void clear();

    /// Reserves room for `items` nodes and ids 0 .. items - 1.
    void reserve(std::int32_t items);

    /// Renumbers the nodes in depth-first order and releases free nodes. The tree and every
    /// query result stay the same; queries then read memory mostly in sequence instead of in
    /// insertion order, which matters once the pool outgrows the caches (about 2x faster
    /// sphere queries on 1M random points). Call after a bulk insertion or a large removal.
    /// Also recomputes every node's subtree bounds exactly. Cost O(pool_size()), temporary
    /// memory 92 B per node.
    void compact();

    /// Ids of the items whose box intersects the closed box `query`, in increasing id order
    /// (written to `out_ids`, which is cleared first). Empty when query.lo > query.hi on some
    /// axis; throws InputError on NaN coordinates. With AdtOrder::walk the same ids come in the
    /// order of the tree walk, unsorted.
    void query_box(const AdtBox& query, std::vector<std::int32_t>& out_ids,
                   AdtOrder order = AdtOrder::by_id) const;

    /// Ids of the items whose box intersects the closed ball (`center`, `radius` mm), i.e.
    /// squared_distance(box, center) <= radius * radius, in increasing id order (written to
    /// `out_ids`, cleared first). Empty for a negative radius; an infinite radius returns all
    /// items. Throws InputError on NaN input. AdtOrder::walk as for query_box.
    void query_sphere(const Eigen::Vector3d& center, double radius,
                      std::vector<std::int32_t>& out_ids, AdtOrder order = AdtOrder::by_id) const;

    /// The item closest to `p` by squared_distance (0 for boxes containing `p`), ties broken by
    /// the smaller id; id -1 when the tree is empty. Throws InputError when `p` is not finite.
    AdtNeighbor nearest(const Eigen::Vector3d& p) const;

    /// The `k` items closest to `p`, ordered by (distance2, id) ascending: the first
    /// min(k, size()) items of that order (written to `out`, cleared first). Throws
    /// InputError when `p` is not finite.
    void nearest_k(const Eigen::Vector3d& p, std::int32_t k, std::vector<AdtNeighbor>& out) const;

    /// The root region given at construction.
    const AdtBox& domain() const { return domain_; }

    /// The kind of items (points or boxes).
    AdtItems items() const { return items_; }

    /// Number of nodes allocated, live or free: at most the largest size() reached since the
    /// last clear().
    std::int32_t pool_size() const { return static_cast<std::int32_t>(nodes_.size()); }

    /// Number of nodes on the longest root-to-leaf path (0 when empty). Cost O(size()).
    std::int32_t max_depth() const;

private:
    // 88 bytes. key = (lo, hi) of the item, lo the key insertion descends by; `bound` encloses
    // the boxes of every item in the node's subtree (the node's own included), rounded outward
    // to float and stored as (lo x, y, z, -hi x, y, z), so that widening is one elementwise
    // min and a box test one elementwise <= (SSE, two overlapping 4-float loads): widened on
    // insert, left as it is on remove (still enclosing), exact after compact(); queries skip a
    // subtree whose bounds miss them. parent -1 at the root; child[0] doubles as the free-list
    // link of a free node (id == -1).
    struct Node {
        double key[6];
        float bound[6];
        std::int32_t id;
        std::int32_t parent;
        std::int32_t child[2];
    };

    void insert_key(std::int32_t node);
    void collect_box(const AdtBox& query, std::vector<std::int32_t>& out_ids) const;
    void collect_sphere(const Eigen::Vector3d& center, double radius2,
                        std::vector<std::int32_t>& out_ids) const;
    void collect_nearest(const Eigen::Vector3d& p, std::size_t k,
                         std::vector<AdtNeighbor>& heap) const;
    std::int32_t allocate_node();

    AdtBox domain_;
    AdtItems items_;
    HugeVector<Node> nodes_;                // pool, addressed by int32 (huge pages when large)
    HugeVector<std::int32_t> node_of_id_;   // id -> node, -1 absent
    std::int32_t root_ = -1;
    std::int32_t free_head_ = -1;
    std::int32_t size_ = 0;
};

}  // namespace frontmesh::core
