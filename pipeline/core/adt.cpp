#include "pipeline/core/adt.h"

#include <emmintrin.h>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <utility>

#include "pipeline/core/error.h"

namespace frontmesh::core {

namespace {

constexpr double infinity = std::numeric_limits<double>::infinity();

// squared_distance of a stored key (lo = key[0..2], hi = key[3..5]) to p; the same value.
inline double key_distance2(const double* key, const Eigen::Vector3d& p) {
    double d2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        const double d = std::max(std::max(key[a] - p[a], p[a] - key[a + 3]), 0.0);
        d2 += d * d;
    }
    return d2;
}

// Node bounds are stored as (lo x, y, z, -hi x, y, z): the union of two is one elementwise
// min, a box test one elementwise <=.

// The stored bounds of an item box (lo x, y, z, hi x, y, z).
inline void set_bound(double* bound, const double* key) {
    std::copy(key, key + 3, bound);
    for (int a = 0; a < 3; ++a) bound[a + 3] = -key[a + 3];
}

// bound := min(bound, other) elementwise (the union of the two boxes); stored only when it
// grows, which leaves fewer dirty cache lines on the insertion path. True when it grew.
inline bool widen_bound(double* bound, const double* other) {
    const __m128d b01 = _mm_loadu_pd(bound), b23 = _mm_loadu_pd(bound + 2),
                  b45 = _mm_loadu_pd(bound + 4);
    const __m128d o01 = _mm_loadu_pd(other), o23 = _mm_loadu_pd(other + 2),
                  o45 = _mm_loadu_pd(other + 4);
    const __m128d grows = _mm_or_pd(_mm_or_pd(_mm_cmplt_pd(o01, b01), _mm_cmplt_pd(o23, b23)),
                                    _mm_cmplt_pd(o45, b45));
    if (_mm_movemask_pd(grows) == 0) return false;
    _mm_storeu_pd(bound, _mm_min_pd(b01, o01));
    _mm_storeu_pd(bound + 2, _mm_min_pd(b23, o23));
    _mm_storeu_pd(bound + 4, _mm_min_pd(b45, o45));
    return true;
}

// The bound of no item: lo = +inf, -hi = +inf, met by no query and widened by any item.
inline void set_empty(double* bound) { std::fill(bound, bound + 6, infinity); }

// A closed query box against item keys (lo x, y, z, hi x, y, z) and node bounds (lo x, y, z,
// -hi x, y, z), in doubles, two axes at a time. Keys: (lo x, lo y) <= (hi x, hi y) of the
// query, (lo z, query lo x) <= (query hi z, hi x), (query lo y, query lo z) <= (hi y, hi z).
// Bounds: (lo x, y, z, -hi x, y, z) <= (query hi x, y, z, -query lo x, y, z).
struct BoxTest {
    __m128d qhi01, qhi2, qlo0, qlo12;  // keys
    __m128d b01, b23, b45;             // bounds
    explicit BoxTest(const AdtBox& query)
        : qhi01(_mm_loadu_pd(query.hi.data())),
          qhi2(_mm_set_sd(query.hi[2])),
          qlo0(_mm_set1_pd(query.lo[0])),
          qlo12(_mm_loadu_pd(query.lo.data() + 1)),
          b01(_mm_setr_pd(query.hi[0], query.hi[1])),
          b23(_mm_setr_pd(query.hi[2], -query.lo[0])),
          b45(_mm_setr_pd(-query.lo[1], -query.lo[2])) {}
    bool key_meets(const double* key) const {
        const __m128d k23 = _mm_loadu_pd(key + 2);
        const __m128d m0 = _mm_cmple_pd(_mm_loadu_pd(key), qhi01);
        const __m128d m1 = _mm_cmple_pd(_mm_move_sd(qlo0, k23), _mm_move_sd(k23, qhi2));
        const __m128d m2 = _mm_cmple_pd(qlo12, _mm_loadu_pd(key + 4));
        return _mm_movemask_pd(_mm_and_pd(_mm_and_pd(m0, m1), m2)) == 3;
    }
    bool bound_meets(const double* bound) const {
        const __m128d m0 = _mm_cmple_pd(_mm_loadu_pd(bound), b01);
        const __m128d m1 = _mm_cmple_pd(_mm_loadu_pd(bound + 2), b23);
        const __m128d m2 = _mm_cmple_pd(_mm_loadu_pd(bound + 4), b45);
        return _mm_movemask_pd(_mm_and_pd(_mm_and_pd(m0, m1), m2)) == 3;
    }
};

// Lower bound of squared_distance(item box, p) over the items of a subtree, from its stored
// bounds. The arithmetic mirrors key_distance2 term by term (the bounds enclose every item
// box, max is exact and rounding is monotone; p - hi is computed as p + (-hi), the same
// double), so the bound never exceeds the computed distance of an item below and pruning
// with it is exact.
template <class Node>
double bound_distance2(const Node& n, const Eigen::Vector3d& p) {
    double d2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        const double d = std::max(std::max(n.bound[a] - p[a], p[a] + n.bound[a + 3]), 0.0);
        d2 += d * d;
    }
    return d2;
}

// Depth-first walk over the subtrees whose stored bounds `meets` accepts; `visit(node)` runs
// on the node of every such subtree, in pre-order (node, first child's subtree, second
// child's subtree), which pruning never reorders. Each node's accepted children go on a stack
// on the call's own frame, the second below the first, and the next node is popped. A node
// has at most Adt::kMaxDepth ancestors and the stack holds at most one entry per level plus
// two, so kStack entries suffice; concurrent const queries share nothing.
template <class Nodes, class Meets, class Visit>
void bounded_walk(const Nodes& nodes, std::int32_t root, Meets&& meets, Visit&& visit) {
    if (root < 0 || !meets(nodes[static_cast<std::size_t>(root)])) return;
    constexpr std::size_t kStack = Adt::kMaxDepth + 4;
    std::int32_t stack[kStack];
    std::int32_t* top = stack;  // next free entry
    std::int32_t node = root;
    while (true) {
        const auto& n = nodes[static_cast<std::size_t>(node)];
        visit(n);
        const std::int32_t c0 = n.child[0];
        const std::int32_t c1 = n.child[1];
        if (c1 >= 0 && meets(nodes[static_cast<std::size_t>(c1)])) *top++ = c1;
        if (c0 >= 0 && meets(nodes[static_cast<std::size_t>(c0)])) *top++ = c0;
        if (top == stack) return;
        FM_CHECK(top < stack + kStack - 2);  // a node deeper than kMaxDepth: never
        node = *--top;
    }
}

bool has_nan(const Eigen::Vector3d& v) { return v.array().isNaN().any(); }

}  // namespace

Adt::Adt(const AdtBox& domain, AdtItems items) : domain_(domain), items_(items) {
    static_assert(sizeof(Node) == 64, "the node size is documented in adt.h");
    if (!domain.is_valid())
        FM_THROW(InternalError, "ADT: root domain must be finite with lo <= hi on every axis");
}

std::int32_t Adt::new_node(std::int32_t depth) {
    FM_CHECK(nodes_.size() < static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()));
    Node n;
    set_empty(n.bound);
    n.child[0] = n.child[1] = -1;
    n.bucket = -1;
    n.depth = depth;
    nodes_.push_back(n);
    return static_cast<std::int32_t>(nodes_.size() - 1);
}

std::int32_t Adt::new_bucket(std::int32_t node) {
    std::int32_t b;
    if (free_bucket_ >= 0) {
        b = free_bucket_;
        free_bucket_ = buckets_[static_cast<std::size_t>(b)].next;
    } else {
        FM_CHECK(buckets_.size() <
                 static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max() / kLeafItems));
        buckets_.emplace_back();
        b = static_cast<std::int32_t>(buckets_.size() - 1);
    }
    Bucket& k = buckets_[static_cast<std::size_t>(b)];
    k.count = 0;
    k.next = k.prev = -1;
    k.node = node;
    return b;
}

void Adt::free_bucket(std::int32_t bucket) {
    Bucket& k = buckets_[static_cast<std::size_t>(bucket)];
    k.count = 0;
    k.prev = -1;
    k.node = -1;
    k.next = free_bucket_;
    free_bucket_ = bucket;
}

void Adt::append(std::int32_t bucket, const Item& item) {
    Bucket& k = buckets_[static_cast<std::size_t>(bucket)];
    const std::int32_t s = k.count++;
    std::copy(item.key, item.key + 6, k.key[s]);
    k.id[s] = item.id;
    slot_of_id_[static_cast<std::size_t>(item.id)] = bucket * kLeafItems + s;
}

// A new bucket after `last`, the last bucket of a leaf's chain.
std::int32_t Adt::grow_chain(std::int32_t last) {
    const std::int32_t next = new_bucket(buckets_[static_cast<std::size_t>(last)].node);
    buckets_[static_cast<std::size_t>(last)].next = next;
    buckets_[static_cast<std::size_t>(next)].prev = last;
    return next;
}

// The items of the chain from `bucket` on, in slot order, appended to `into`.
void Adt::copy_items(std::int32_t bucket, std::vector<Item>& into) const {
    for (std::int32_t b = bucket; b >= 0; b = buckets_[static_cast<std::size_t>(b)].next) {
        const Bucket& k = buckets_[static_cast<std::size_t>(b)];
        for (std::int32_t s = 0; s < k.count; ++s) {
            Item item;
            std::copy(k.key[s], k.key[s] + 6, item.key);
            item.id = k.id[s];
            into.push_back(item);
        }
    }
}

// Makes `node` a leaf holding scratch_[first, last) in that order, in as many buckets as
// they need, with exact bounds.
void Adt::make_leaf(std::int32_t node, std::size_t first, std::size_t last) {
    double bound[6];
    set_empty(bound);
    std::int32_t b = new_bucket(node);
    nodes_[static_cast<std::size_t>(node)].bucket = b;
    for (std::size_t i = first; i < last; ++i) {
        if (buckets_[static_cast<std::size_t>(b)].count == kLeafItems) b = grow_chain(b);
        append(b, scratch_[i]);
        double item_bound[6];
        set_bound(item_bound, scratch_[i].key);
        widen_bound(bound, item_bound);
    }
    std::copy(bound, bound + 6, nodes_[static_cast<std::size_t>(node)].bound);
}

// Makes `node` (of region [region_lo, region_hi], its depth set) the subtree of the items
// scratch_[first, last): a leaf when they fit in a bucket or cannot be told apart (identical
// clamped keys, or the depth limit), else a split at the region's midpoint in key coordinate
// depth mod 3, the rule insertion descends by, with each non-empty half filled the same way.
// Items keep their order within each half. The node's bound becomes exact.
void Adt::fill(std::int32_t node, const double* region_lo, const double* region_hi,
               std::size_t first, std::size_t last) {
    const std::int32_t depth = nodes_[static_cast<std::size_t>(node)].depth;
    auto clamped = [&](const Item& item, int a) {
        return std::clamp(item.key[a], domain_.lo[a], domain_.hi[a]);
    };
    bool same = true;
    for (std::size_t i = first + 1; i < last && same; ++i)
        for (int a = 0; a < 3 && same; ++a)
            same = clamped(scratch_[i], a) == clamped(scratch_[first], a);
    if (last - first <= static_cast<std::size_t>(kLeafItems) || same || depth >= kMaxDepth) {
        make_leaf(node, first, last);
        return;
    }
    const int axis = depth % 3;
    const double split = 0.5 * region_lo[axis] + 0.5 * region_hi[axis];
    const auto begin = scratch_.begin() + static_cast<std::ptrdiff_t>(first);
    const auto end = scratch_.begin() + static_cast<std::ptrdiff_t>(last);
    const std::size_t mid =
        first + static_cast<std::size_t>(
                    std::stable_partition(
                        begin, end, [&](const Item& item) { return clamped(item, axis) < split; }) -
                    begin);
    nodes_[static_cast<std::size_t>(node)].bucket = -1;
    set_empty(nodes_[static_cast<std::size_t>(node)].bound);  // the union of its halves'
    for (int side = 0; side < 2; ++side) {
        const std::size_t lo = side == 0 ? first : mid, hi = side == 0 ? mid : last;
        if (lo == hi) continue;
        double child_lo[3], child_hi[3];
        std::copy(region_lo, region_lo + 3, child_lo);
        std::copy(region_hi, region_hi + 3, child_hi);
        (side == 0 ? child_hi : child_lo)[axis] = split;
        const std::int32_t child = new_node(depth + 1);
        nodes_[static_cast<std::size_t>(node)].child[side] = child;
        fill(child, child_lo, child_hi, lo, hi);
        widen_bound(nodes_[static_cast<std::size_t>(node)].bound,
                    nodes_[static_cast<std::size_t>(child)].bound);
    }
}

void Adt::insert(std::int32_t id, const Eigen::Vector3d& p) {
    if (!p.allFinite())
        FM_THROW(InternalError, "ADT: point of item " + std::to_string(id) + " is not finite");
    insert(id, AdtBox::of_point(p));
}

// Bonet & Peraire: descend from the root bisecting the node's region of key space in key
// coordinate depth mod 3 (an item's key is the low corner of its box, the point itself for
// points). Keys outside the domain are clamped onto it to choose a branch. The region starts
// as the domain and each level halves it at split = 0.5 lo + 0.5 hi, which lies in [lo, hi].
// Every node on the way gets its subtree bounds widened to the new item's (from the bottom up,
// as far as they grow). The item joins
// the leaf it reaches (a new leaf in an empty half); a full leaf is filled anew with its
// items and the new one, which splits it.
void Adt::insert(std::int32_t id, const AdtBox& box) {
    FM_CHECK(id >= 0);
    FM_CHECK(!contains(id));
    if (!box.is_valid())
        FM_THROW(InternalError, "ADT: box of item " + std::to_string(id) +
                                    " is not finite or has lo > hi on some axis");
    FM_CHECK(items_ == AdtItems::boxes || box.lo == box.hi);

    Item item;
    for (int a = 0; a < 3; ++a) {
        item.key[a] = box.lo[a];
        item.key[a + 3] = box.hi[a];
    }
    item.id = id;
    double item_bound[6];
    set_bound(item_bound, item.key);
    if (static_cast<std::size_t>(id) >= slot_of_id_.size())
        slot_of_id_.resize(static_cast<std::size_t>(id) + 1, -1);
    ++size_;
    auto new_leaf = [&](std::int32_t depth) {
        const std::int32_t leaf = new_node(depth);
        const std::int32_t b = new_bucket(leaf);
        Node& n = nodes_[static_cast<std::size_t>(leaf)];
        n.bucket = b;
        std::copy(item_bound, item_bound + 6, n.bound);
        append(b, item);
        return leaf;
    };
    if (root_ < 0) {
        root_ = new_leaf(0);
        return;
    }

    Node* const pool = nodes_.data();  // no node is allocated during the descent
    const double kx = std::clamp(item.key[0], domain_.lo[0], domain_.hi[0]);
    const double ky = std::clamp(item.key[1], domain_.lo[1], domain_.hi[1]);
    const double kz = std::clamp(item.key[2], domain_.lo[2], domain_.hi[2]);
    double lx = domain_.lo[0], hx = domain_.hi[0], ly = domain_.lo[1], hy = domain_.hi[1];
    double lz = domain_.lo[2], hz = domain_.hi[2];
    std::int32_t at = root_;
    int empty_side = -1;
    // The nodes passed, path[d] at depth d. Their bounds are widened afterwards from the
    // bottom up, as far as they grow: a node's bounds enclose those of its children (each
    // is widened with them, compact() and fill() make them exact unions), so above one that
    // already encloses the item every one does.
    std::int32_t* const path = path_;
    std::int32_t depth = 0;
    // The descent starts from the finger (the node where the last one ended) when the key
    // lies in its region: the root's descent would pass it, taking the same sides (lo <= k <
    // hi on every axis; a key on the domain's upper face starts at the root). path_[0, finger
    // depth) still holds the nodes above it. Consecutive insertions are mostly close together
    // (tetra on Colin27: 2.85% fewer instructions for the stage than descents from the root;
    // a finger 1, 2, 3 or 5 levels higher saved less).
    int start_axis = 0;
    if (finger_node_ >= 0 && finger_lo_[0] <= kx && kx < finger_hi_[0] && finger_lo_[1] <= ky &&
        ky < finger_hi_[1] && finger_lo_[2] <= kz && kz < finger_hi_[2]) {
        at = finger_node_;
        depth = finger_depth_;
        lx = finger_lo_[0], ly = finger_lo_[1], lz = finger_lo_[2];
        hx = finger_hi_[0], hy = finger_hi_[1], hz = finger_hi_[2];
        start_axis = depth % 3;
    }
    auto widen_up = [&](std::int32_t from) {
        for (std::int32_t d = from;
             d >= 0 && widen_bound(nodes_[static_cast<std::size_t>(path[d])].bound, item_bound);
             --d) {
        }
    };
    // One level on one axis: true when the descent ends there, at a leaf (`at`) or at an empty
    // half of `at` (empty_side). The axes x, y, z follow one another in the unrolled loop
    // below (the root splits x); the region bounds stay in registers.
    auto level = [&](double k, double& lo, double& hi) {
        const Node& n = pool[at];
        path[depth] = at;
        if (n.bucket >= 0) return true;
        const double split = 0.5 * lo + 0.5 * hi;
        const int side = k < split ? 0 : 1;
        const double before = side == 0 ? hi : lo;
        (side == 0 ? hi : lo) = split;
        const std::int32_t child = n.child[side];
        if (child < 0) {
            empty_side = side;
            (side == 0 ? hi : lo) = before;  // the region of `at`, the finger
            return true;
        }
        at = child;
        ++depth;
        return false;
    };
    bool ended = false;
    if (start_axis == 1) ended = level(ky, ly, hy) || level(kz, lz, hz);
    if (start_axis == 2) ended = level(kz, lz, hz);
    if (!ended)
        while (!level(kx, lx, hx) && !level(ky, ly, hy) && !level(kz, lz, hz)) {
        }
    finger_node_ = at;
    finger_depth_ = depth;
    finger_lo_[0] = lx, finger_lo_[1] = ly, finger_lo_[2] = lz;
    finger_hi_[0] = hx, finger_hi_[1] = hy, finger_hi_[2] = hz;
    if (empty_side >= 0) {
        const std::int32_t leaf = new_leaf(depth + 1);
        nodes_[static_cast<std::size_t>(at)].child[empty_side] = leaf;
        widen_up(depth);
        return;
    }
    const std::int32_t head = nodes_[static_cast<std::size_t>(at)].bucket;
    std::int32_t last = head;
    while (buckets_[static_cast<std::size_t>(last)].next >= 0)
        last = buckets_[static_cast<std::size_t>(last)].next;
    if (buckets_[static_cast<std::size_t>(last)].count < kLeafItems) {
        append(last, item);
        widen_up(depth);
        return;
    }
    // A full leaf. A chain (items of one key) whose key the item shares, or a leaf at the
    // depth limit, grows by a bucket; any other is filled anew, which splits it.
    const Bucket& first = buckets_[static_cast<std::size_t>(head)];
    const bool same_key = first.next >= 0 &&
                          std::clamp(first.key[0][0], domain_.lo[0], domain_.hi[0]) == kx &&
                          std::clamp(first.key[0][1], domain_.lo[1], domain_.hi[1]) == ky &&
                          std::clamp(first.key[0][2], domain_.lo[2], domain_.hi[2]) == kz;
    if (same_key || nodes_[static_cast<std::size_t>(at)].depth >= kMaxDepth) {
        append(grow_chain(last), item);
        widen_up(depth);
        return;
    }
    scratch_.clear();
    copy_items(head, scratch_);
    for (std::int32_t b = head; b >= 0;) {
        const std::int32_t next = buckets_[static_cast<std::size_t>(b)].next;
        free_bucket(b);
        b = next;
    }
    scratch_.push_back(item);
    const double region_lo[3] = {lx, ly, lz}, region_hi[3] = {hx, hy, hz};
    fill(at, region_lo, region_hi, 0, scratch_.size());  // its bounds: exact, with the item
    widen_up(depth - 1);
}

bool Adt::remove(std::int32_t id) {
    if (!contains(id)) return false;
    const std::int32_t slot = slot_of_id_[static_cast<std::size_t>(id)];
    slot_of_id_[static_cast<std::size_t>(id)] = -1;
    const std::int32_t b = slot / kLeafItems, s = slot % kLeafItems;
    // The last item of the leaf takes the slot.
    std::int32_t last = b;
    while (buckets_[static_cast<std::size_t>(last)].next >= 0)
        last = buckets_[static_cast<std::size_t>(last)].next;
    Bucket& tail = buckets_[static_cast<std::size_t>(last)];
    const std::int32_t t = --tail.count;
    if (last != b || t != s) {
        Bucket& k = buckets_[static_cast<std::size_t>(b)];
        std::copy(tail.key[t], tail.key[t] + 6, k.key[s]);
        k.id[s] = tail.id[t];
        slot_of_id_[static_cast<std::size_t>(k.id[s])] = slot;
    }
    if (tail.count == 0) {
        if (tail.prev >= 0) {  // the end of a chain
            buckets_[static_cast<std::size_t>(tail.prev)].next = -1;
            free_bucket(last);
        } else {  // the leaf is empty: no query needs to look at it
            set_empty(nodes_[static_cast<std::size_t>(tail.node)].bound);
        }
    }
    --size_;
    // The subtree bounds above are left as they are: they still enclose every item below,
    // only more loosely; compact() makes them exact again.
    return true;
}

AdtBox Adt::box(std::int32_t id) const {
    FM_CHECK(contains(id));
    const std::int32_t slot = slot_of_id_[static_cast<std::size_t>(id)];
    const double* key =
        buckets_[static_cast<std::size_t>(slot / kLeafItems)].key[slot % kLeafItems];
    return {Eigen::Vector3d(key[0], key[1], key[2]), Eigen::Vector3d(key[3], key[4], key[5])};
}

void Adt::clear() {
    finger_node_ = -1;
    nodes_.clear();
    buckets_.clear();
    slot_of_id_.clear();
    root_ = -1;
    free_bucket_ = -1;
    size_ = 0;
}

void Adt::reserve(std::int32_t items) {
    if (items <= 0) return;
    nodes_.reserve(static_cast<std::size_t>(4 * (items / kLeafItems) + 1));
    buckets_.reserve(static_cast<std::size_t>(2 * (items / kLeafItems) + 1));
    slot_of_id_.reserve(static_cast<std::size_t>(items));
}

void Adt::compact() {
    finger_node_ = -1;  // nodes are renumbered
    // Items per subtree, children after parents in pre-order.
    std::vector<std::int32_t> order, count(nodes_.size(), 0), stack;
    if (root_ >= 0) stack.push_back(root_);
    while (!stack.empty()) {
        const std::int32_t node = stack.back();
        stack.pop_back();
        order.push_back(node);
        for (const std::int32_t child : nodes_[static_cast<std::size_t>(node)].child)
            if (child >= 0) stack.push_back(child);
    }
    for (std::size_t i = order.size(); i-- > 0;) {
        const Node& n = nodes_[static_cast<std::size_t>(order[i])];
        std::int32_t c = 0;
        if (n.bucket >= 0) {
            for (std::int32_t b = n.bucket; b >= 0; b = buckets_[static_cast<std::size_t>(b)].next)
                c += buckets_[static_cast<std::size_t>(b)].count;
        } else {
            for (const std::int32_t child : n.child)
                if (child >= 0) c += count[static_cast<std::size_t>(child)];
        }
        count[static_cast<std::size_t>(order[i])] = c;
    }
    Adt out(domain_, items_);
    out.slot_of_id_ = std::move(slot_of_id_);
    out.nodes_.reserve(order.size());
    out.buckets_.reserve(static_cast<std::size_t>(size_ / (kLeafItems / 2) + 1));
    // The items of an old subtree in walk order.
    auto gather = [&](auto& self, std::int32_t node) -> void {
        const Node& n = nodes_[static_cast<std::size_t>(node)];
        if (n.bucket >= 0) {
            copy_items(n.bucket, out.scratch_);
            return;
        }
        for (const std::int32_t child : n.child)
            if (child >= 0) self(self, child);
    };
    // The new copy of an old subtree, in pre-order: a leaf where the subtree's items fit in
    // one bucket (or it is a chain), else a split with the same halves. -1 when empty.
    auto build = [&](auto& self, std::int32_t node) -> std::int32_t {
        if (count[static_cast<std::size_t>(node)] == 0) return -1;
        const Node& n = nodes_[static_cast<std::size_t>(node)];
        const std::int32_t at = out.new_node(n.depth);
        if (n.bucket >= 0 || count[static_cast<std::size_t>(node)] <= kLeafItems) {
            out.scratch_.clear();
            gather(gather, node);
            out.make_leaf(at, 0, out.scratch_.size());
            return at;
        }
        double bound[6];
        set_empty(bound);
        for (int side = 0; side < 2; ++side) {
            const std::int32_t child = n.child[side];
            const std::int32_t copy = child >= 0 ? self(self, child) : -1;
            out.nodes_[static_cast<std::size_t>(at)].child[side] = copy;
            if (copy >= 0) widen_bound(bound, out.nodes_[static_cast<std::size_t>(copy)].bound);
        }
        std::copy(bound, bound + 6, out.nodes_[static_cast<std::size_t>(at)].bound);
        return at;
    };
    out.root_ = root_ >= 0 ? build(build, root_) : -1;
    out.size_ = size_;
    out.scratch_.clear();
    nodes_ = std::move(out.nodes_);
    buckets_ = std::move(out.buckets_);
    slot_of_id_ = std::move(out.slot_of_id_);
    root_ = out.root_;
    free_bucket_ = out.free_bucket_;
}

void Adt::collect_box(const AdtBox& query, std::vector<std::int32_t>& out_ids) const {
    // A subtree is skipped when its bounds miss the query; the items of the leaves reached
    // are tested, in the same doubles.
    const BoxTest test(query);
    auto meets = [&](const Node& n) { return test.bound_meets(n.bound); };
    const Bucket* const buckets = buckets_.data();
    // Every item of a leaf is written, the count advanced only for those that meet the query:
    // no branch on the test, which no predictor guesses well (tetra on Colin27: this function
    // had a fifth of the run's mispredicted branches; without them, and with the walk's stack
    // on the frame, the stage took 5% less time). out_ids keeps room for a bucket more.
    std::size_t found = out_ids.size();
    out_ids.resize(found + 4 * kLeafItems);
    auto visit = [&](const Node& n) {
        for (std::int32_t b = n.bucket; b >= 0; b = buckets[b].next) {
            const Bucket& k = buckets[b];
            if (found + kLeafItems > out_ids.size()) out_ids.resize(2 * out_ids.size());
            std::int32_t* const out = out_ids.data();
            for (std::int32_t s = 0; s < k.count; ++s) {
                out[found] = k.id[s];
                found += test.key_meets(k.key[s]);
            }
        }
    };
    bounded_walk(nodes_, root_, meets, visit);
    out_ids.resize(found);
}

void Adt::query_box(const AdtBox& query, std::vector<std::int32_t>& out_ids, AdtOrder order) const {
    out_ids.clear();
    if (has_nan(query.lo) || has_nan(query.hi))
        FM_THROW(InternalError, "ADT: query box has a NaN coordinate");
    if ((query.lo.array() > query.hi.array()).any()) return;
    collect_box(query, out_ids);
    if (order == AdtOrder::by_id) std::sort(out_ids.begin(), out_ids.end());
}
namespace {

// bound_distance2 and key_distance2 with x and y in one SSE2 register: the same operations
// on the same doubles in the same order (max of equal values may pick the other zero, whose
// square is the same), so the same results bit for bit.
struct SphereTest {
    __m128d p01;
    double p2;
    explicit SphereTest(const Eigen::Vector3d& p) : p01(_mm_loadu_pd(p.data())), p2(p[2]) {}
    double finish(__m128d lo_gap, __m128d hi_gap, double lo_gap2, double hi_gap2) const {
        const __m128d d = _mm_max_pd(_mm_max_pd(lo_gap, hi_gap), _mm_setzero_pd());
        const __m128d sq = _mm_mul_pd(d, d);
        const double d2 = std::max(std::max(lo_gap2, hi_gap2), 0.0);
        return (_mm_cvtsd_f64(sq) + _mm_cvtsd_f64(_mm_unpackhi_pd(sq, sq))) + d2 * d2;
    }
    // node bounds (lo x, y, z, -hi x, y, z)
    double bound_distance2(const double* b) const {
        return finish(_mm_sub_pd(_mm_loadu_pd(b), p01), _mm_add_pd(p01, _mm_loadu_pd(b + 3)),
                      b[2] - p2, p2 + b[5]);
    }
    // item keys (lo x, y, z, hi x, y, z)
    double key_distance2(const double* k) const {
        return finish(_mm_sub_pd(_mm_loadu_pd(k), p01), _mm_sub_pd(p01, _mm_loadu_pd(k + 3)),
                      k[2] - p2, p2 - k[5]);
    }
};

}  // namespace

void Adt::collect_sphere(const Eigen::Vector3d& center, double radius2,
                         std::vector<std::int32_t>& out_ids) const {
    const SphereTest test(center);
    auto meets = [&](const Node& n) { return test.bound_distance2(n.bound) <= radius2; };
    const Bucket* const buckets = buckets_.data();
    auto visit = [&](const Node& n) {
        for (std::int32_t b = n.bucket; b >= 0; b = buckets[b].next) {
            const Bucket& k = buckets[b];
            for (std::int32_t s = 0; s < k.count; ++s)
                if (test.key_distance2(k.key[s]) <= radius2) out_ids.push_back(k.id[s]);
        }
    };
    bounded_walk(nodes_, root_, meets, visit);
}

void Adt::query_sphere(const Eigen::Vector3d& center, double radius,
                       std::vector<std::int32_t>& out_ids, AdtOrder order) const {
    out_ids.clear();
    if (!center.allFinite() || std::isnan(radius))
        FM_THROW(InternalError, "ADT: sphere query has a non-finite centre or a NaN radius");
    if (radius < 0.0) return;
    collect_sphere(center, radius * radius, out_ids);
    if (order == AdtOrder::by_id) std::sort(out_ids.begin(), out_ids.end());
}

namespace {

// Order of nearest-query results: by squared distance, then by id.
bool closer(const AdtNeighbor& a, const AdtNeighbor& b) {
    return a.distance2 < b.distance2 || (a.distance2 == b.distance2 && a.id < b.id);
}

}  // namespace

// Depth-first branch and bound keeping the k best items in a max-heap under `closer`. Of two
// children the one whose bounds lie nearer to p is visited first; a subtree is skipped only
// when the lower bound of its bounds exceeds the k-th best distance strictly, so equal
// distances with smaller ids are still found.
void Adt::collect_nearest(const Eigen::Vector3d& p, std::size_t k,
                          std::vector<AdtNeighbor>& heap) const {
    if (root_ < 0 || k == 0) return;
    auto bound = [&] { return heap.size() < k ? infinity : heap.front().distance2; };
    struct Waiting {
        std::int32_t node;
        double distance2;  // lower bound over the subtree
    };
    thread_local std::vector<Waiting> stack;  // per thread, at most one entry per level
    stack.clear();
    std::int32_t node = root_;
    while (true) {
        const Node& n = nodes_[static_cast<std::size_t>(node)];
        bool has_next = false;
        if (n.bucket >= 0) {
            for (std::int32_t b = n.bucket; b >= 0;
                 b = buckets_[static_cast<std::size_t>(b)].next) {
                const Bucket& items = buckets_[static_cast<std::size_t>(b)];
                for (std::int32_t s = 0; s < items.count; ++s) {
                    const AdtNeighbor candidate{items.id[s], key_distance2(items.key[s], p)};
                    if (heap.size() < k) {
                        heap.push_back(candidate);
                        std::push_heap(heap.begin(), heap.end(), closer);
                    } else if (closer(candidate, heap.front())) {
                        std::pop_heap(heap.begin(), heap.end(), closer);
                        heap.back() = candidate;
                        std::push_heap(heap.begin(), heap.end(), closer);
                    }
                }
            }
        } else {
            // The nearer child continues in place, the other waits with its bound.
            Waiting next[2];
            int count = 0;
            for (const std::int32_t child : n.child) {
                if (child < 0) continue;
                const double d2 = bound_distance2(nodes_[static_cast<std::size_t>(child)], p);
                if (d2 <= bound()) next[count++] = {child, d2};
            }
            if (count == 2 && next[1].distance2 < next[0].distance2) std::swap(next[0], next[1]);
            if (count == 2) stack.push_back(next[1]);
            has_next = count > 0;
            if (has_next) node = next[0].node;
        }
        // A waiting subtree is dropped when the best distances shrank below its bound.
        while (!has_next && !stack.empty()) {
            const Waiting w = stack.back();
            stack.pop_back();
            has_next = w.distance2 <= bound();
            node = w.node;
        }
        if (!has_next) return;
    }
}

AdtNeighbor Adt::nearest(const Eigen::Vector3d& p) const {
    thread_local std::vector<AdtNeighbor> best;  // per thread: no allocation per query
    nearest_k(p, 1, best);
    return best.empty() ? AdtNeighbor{} : best.front();
}

void Adt::nearest_k(const Eigen::Vector3d& p, std::int32_t k, std::vector<AdtNeighbor>& out) const {
    out.clear();
    if (!p.allFinite()) FM_THROW(InternalError, "ADT: nearest query point is not finite");
    if (k <= 0) return;
    const std::size_t count = static_cast<std::size_t>(std::min(k, size_));
    out.reserve(count);
    collect_nearest(p, count, out);
    std::sort_heap(out.begin(), out.end(), closer);
}

std::int32_t Adt::max_depth() const {
    if (root_ < 0) return 0;
    std::int32_t deepest = 0;
    std::vector<std::pair<std::int32_t, std::int32_t>> stack{{root_, 1}};
    while (!stack.empty()) {
        const auto [node, depth] = stack.back();
        stack.pop_back();
        deepest = std::max(deepest, depth);
        for (const std::int32_t child : nodes_[static_cast<std::size_t>(node)].child)
            if (child >= 0) stack.emplace_back(child, depth + 1);
    }
    return deepest;
}

}  // namespace frontmesh::core
