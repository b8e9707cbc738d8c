#pragma once
// Alternating digital tree (J. Bonet and J. Peraire, IJNME 31, 1991): the one geometric
// search structure of frontmesh (STYLE §2), used by remesh (background faces) and tetra
// (front nodes, paper §3.1.3-3.1.4).
//
// An item is a closed axis-aligned box (a point is a box with lo == hi); its key is the low
// corner of its box. Every tree node bisects its region of key space in one key coordinate, x,
// y, z alternating with the depth, at the region's midpoint, as in Bonet and Peraire's tree.
// Unlike theirs, the items live in buckets at the leaves, up to kLeafItems each: a full leaf
// splits in two. Queries prune with a bounding box stored per node, the union of the item
// boxes in its subtree, and test the items of a leaf they reach one after the other in one
// block of memory. Bonet and Peraire hold one item in every node and key a box by the 6-D
// point (x_min, y_min, z_min, x_max, y_max, z_max), whose key-space regions bound the boxes
// for pruning; the stored subtree bounds do that here, more tightly, and 3-D keys keep the
// tree shallow. Against one item per node (the tree frontmesh had before), tests/bench/bench_adt:
// sphere and box queries on 200k triangle boxes 1.2 to 1.7x faster, building and churn 1.1 to
// 1.3x; the tetra stage on the Colin27 brain about 4% faster.
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
        // selects, which compile without a branch (a branch here was mispredicted often in
        // tetra's Eq. 5 loop); a NaN gap counts as 0, as it always has
        const double lo_gap = box.lo[a] - p[a], hi_gap = p[a] - box.hi[a];
        double d = lo_gap > 0.0 ? lo_gap : 0.0;
        d = hi_gap > d ? hi_gap : d;
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
/// tree is agnostic to their kind), with insertion, O(1) removal and box, sphere and nearest
/// queries.
///
/// Memory: 53 bytes per item slot (its key as 6 doubles, its id) in leaf buckets of
/// kLeafItems slots, mostly half full or more after compact(); one 64-byte tree node per leaf
/// and split; a 4-byte id->slot entry per id value up to the largest id. About 0.12 GB per
/// million items with dense ids. Emptied bucket slots are reused by later
/// insertions into the same leaf. Ids index the id->slot table directly: keep them dense.
///
/// Depth is O(log n) for spread-out items. Items with identical (clamped) keys cannot be told
/// apart by the tree: they share one leaf whose bucket grows a chain of further buckets, so
/// queries near k such items cost O(k). Traversals are iterative, with a stack of about one
/// node index per level (on the call's frame for box and sphere queries, per thread and 16 B
/// an entry for nearest). Subtree bounds are widened on insert
/// and kept on remove (a leaf left empty drops its own): they stay conservative (never smaller
/// than the items below) but may be looser than exact until `compact`, which recomputes them,
/// merges sparse subtrees into single leaves and lays the nodes and buckets out depth-first.
///
/// Thread safety: const member functions may run concurrently with each other (each thread
/// uses its own traversal stack); any mutation needs exclusive access.
///
/// Every coordinate reaching the tree is computed by frontmesh (the readers reject non-finite
/// input), so a non-finite or reversed argument is a bug of the caller: InternalError (exit 1),
/// never InputError.
class Adt {
public:
    /// An empty tree whose root region is `domain` (e.g. the input's bounding box slightly
    /// enlarged). Throws InternalError when `domain` is not finite or lo > hi on some axis.
    /// A zero extent on an axis is allowed but gives that axis no separating power.
    Adt(const AdtBox& domain, AdtItems items);

    /// Inserts the point `p` under `id`. Valid for both kinds (a point is a degenerate box).
    /// Preconditions: id >= 0 and not present (else InternalError); throws InternalError when
    /// `p` is not finite. Cost O(depth).
    void insert(std::int32_t id, const Eigen::Vector3d& p);

    /// Inserts the box `box` under `id`. A tree of points accepts only degenerate boxes.
    /// Preconditions: id >= 0 and not present, and (points tree) box.lo == box.hi, else
    /// InternalError; throws InternalError when `box` is not valid. Cost O(depth), less when the
    /// key falls in the region of the node where the last insertion ended: the descent starts
    /// there (the same tree as from the root).
    void insert(std::int32_t id, const AdtBox& box);

    /// Removes `id`; false when it is not present. The last item of its leaf takes its slot.
    /// Cost O(1) (O(k) in a chain of k buckets).
    bool remove(std::int32_t id);

    /// True when `id` is present.
    bool contains(std::int32_t id) const {
        return id >= 0 && id < static_cast<std::int32_t>(slot_of_id_.size()) &&
               slot_of_id_[static_cast<std::size_t>(id)] >= 0;
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

    /// Rebuilds the tree's layout: subtrees of at most kLeafItems items become one leaf,
    /// empty leaves go, nodes and buckets are renumbered depth-first (queries then read memory
    /// mostly in sequence, which matters once the tree outgrows the caches) and every subtree
    /// bound becomes exact. Every query result stays the same as a set (the walk order may
    /// change). Call after a bulk insertion or a large removal. Cost O(pool_size() + size()),
    /// temporary memory about 70 B per item.
    void compact();

    /// Ids of the items whose box intersects the closed box `query`, in increasing id order
    /// (written to `out_ids`, which is cleared first). Empty when query.lo > query.hi on some
    /// axis; throws InternalError on NaN coordinates. With AdtOrder::walk the same ids come in the
    /// order of the tree walk, unsorted.
    void query_box(const AdtBox& query, std::vector<std::int32_t>& out_ids,
                   AdtOrder order = AdtOrder::by_id) const;

    /// Ids of the items whose box intersects the closed ball (`center`, `radius` mm), i.e.
    /// squared_distance(box, center) <= radius * radius, in increasing id order (written to
    /// `out_ids`, cleared first). Empty for a negative radius; an infinite radius returns all
    /// items. Throws InternalError on NaN input. AdtOrder::walk as for query_box.
    void query_sphere(const Eigen::Vector3d& center, double radius,
                      std::vector<std::int32_t>& out_ids, AdtOrder order = AdtOrder::by_id) const;

    /// The item closest to `p` by squared_distance (0 for boxes containing `p`), ties broken by
    /// the smaller id; id -1 when the tree is empty. Throws InternalError when `p` is not finite.
    AdtNeighbor nearest(const Eigen::Vector3d& p) const;

    /// The `k` items closest to `p`, ordered by (distance2, id) ascending: the first
    /// min(k, size()) items of that order (written to `out`, cleared first). Throws
    /// InternalError when `p` is not finite.
    void nearest_k(const Eigen::Vector3d& p, std::int32_t k, std::vector<AdtNeighbor>& out) const;

    /// The root region given at construction.
    const AdtBox& domain() const { return domain_; }

    /// The kind of items (points or boxes).
    AdtItems items() const { return items_; }

    /// Number of tree nodes (splits and leaves) allocated. After compact() at most about
    /// 4 size() / kLeafItems + 1 for spread-out items.
    std::int32_t pool_size() const { return static_cast<std::int32_t>(nodes_.size()); }

    /// Number of leaf buckets allocated (each holds up to kLeafItems items).
    std::int32_t bucket_count() const { return static_cast<std::int32_t>(buckets_.size()); }

    /// Items per leaf bucket.
    static constexpr std::int32_t kLeafItems = 16;
    /// Depth of the deepest possible node: a subtree this deep stops splitting (64 halvings
    /// per axis, beyond which a region of doubles hardly shrinks) and its leaf chains buckets.
    static constexpr std::int32_t kMaxDepth = 192;

    /// Number of nodes on the longest root-to-leaf path (0 when empty). Cost O(size()).
    std::int32_t max_depth() const;

private:
    // 64 bytes. `bound` encloses the boxes of every item in the node's subtree, stored as
    // (lo x, y, z, -hi x, y, z), so that widening is one elementwise min and a box test one
    // elementwise <= (SSE2, three pairs): widened on insert, left as it is on remove
    // (still enclosing; empty for a leaf left without items), exact after compact(); queries
    // skip a subtree whose bounds miss them. A split has `bucket` -1 and children (-1 for an
    // empty half); a leaf has its first bucket and no children.
    struct Node {
        double bound[6];
        std::int32_t child[2];
        std::int32_t bucket;
        std::int32_t depth;
    };
    // The items of a leaf: `count` of them in slot order (key = lo x, y, z, hi x, y, z of the
    // item's box), then the leaf's next bucket (a chain only where more than kLeafItems items
    // share one key). A free bucket has node -1 and `next` as its free-list link.
    struct Bucket {
        double key[kLeafItems][6];
        std::int32_t id[kLeafItems];
        std::int32_t count;
        std::int32_t next;  // next bucket of the leaf, -1
        std::int32_t prev;  // previous bucket of the leaf, -1 for its first
        std::int32_t node;  // the leaf
    };
    // An item on its way through fill().
    struct Item {
        double key[6];
        std::int32_t id;
    };

    std::int32_t new_node(std::int32_t depth);
    std::int32_t new_bucket(std::int32_t node);
    void free_bucket(std::int32_t bucket);
    void append(std::int32_t bucket, const Item& item);
    std::int32_t grow_chain(std::int32_t last);
    void copy_items(std::int32_t bucket, std::vector<Item>& into) const;
    void make_leaf(std::int32_t node, std::size_t first, std::size_t last);
    void fill(std::int32_t node, const double* region_lo, const double* region_hi,
              std::size_t first, std::size_t last);
    void collect_box(const AdtBox& query, std::vector<std::int32_t>& out_ids) const;
    void collect_sphere(const Eigen::Vector3d& center, double radius2,
                        std::vector<std::int32_t>& out_ids) const;
    void collect_nearest(const Eigen::Vector3d& p, std::size_t k,
                         std::vector<AdtNeighbor>& heap) const;

    AdtBox domain_;
    AdtItems items_;
    HugeVector<Node> nodes_;               // tree nodes, root first after compact
    HugeVector<Bucket> buckets_;           // leaf buckets (huge pages when large)
    HugeVector<std::int32_t> slot_of_id_;  // id -> bucket * kLeafItems + slot, -1 absent
    std::vector<Item> scratch_;            // items being redistributed by fill()
    std::int32_t root_ = -1;
    std::int32_t free_bucket_ = -1;
    std::int32_t size_ = 0;

    // Insertion state. path_[d]: the node at depth d on the last descent. The finger: the node
    // where it ended (a leaf, or the node it gave a new leaf), with its key-space region; the
    // next descent starts there when its key lies in that region. Nodes are never freed but
    // by compact() and clear(), which drop the finger.
    std::int32_t path_[kMaxDepth + 2];
    std::int32_t finger_node_ = -1;
    std::int32_t finger_depth_ = 0;
    double finger_lo_[3] = {0.0, 0.0, 0.0}, finger_hi_[3] = {0.0, 0.0, 0.0};
};

}  // namespace frontmesh::core
