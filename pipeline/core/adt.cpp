#include "pipeline/core/adt.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "pipeline/core/error.h"

namespace frontmesh::core {

namespace {

constexpr double infinity = std::numeric_limits<double>::infinity();

// Key dimension: an item's key is the low corner of its box (the point itself for points).
constexpr int K = 3;

// A node's region of key space, with the node, as insertion walks it (queries prune with the
// nodes' stored subtree bounds instead). Keys are clamped to the domain only to choose a
// branch, so a side of the region still on the domain boundary is stored as -inf / +inf; the
// split value is rebuilt from the domain.
struct Frame {
    std::int32_t node;
    std::uint32_t k;  // key coordinate the node splits, 0 .. K - 1
    double lo[K];
    double hi[K];
};

Frame root_frame(std::int32_t root) {
    Frame f;
    f.node = root;
    f.k = 0;
    for (int k = 0; k < K; ++k) {
        f.lo[k] = -infinity;
        f.hi[k] = infinity;
    }
    return f;
}

// Bisection value of the node's region in coordinate f.k. 0.5 lo + 0.5 hi cannot overflow
// and lies in [lo, hi].
double split_value(const Frame& f, const AdtBox& domain) {
    const int a = static_cast<int>(f.k);
    const double lo = std::max(f.lo[f.k], domain.lo[a]);
    const double hi = std::min(f.hi[f.k], domain.hi[a]);
    return 0.5 * lo + 0.5 * hi;
}

// Turns frame `f` of a node into the frame of its child on `side` (0: clamped key < split,
// 1: clamped key >= split). A split on the domain boundary (zero extent or exhausted
// precision) bounds nothing.
void descend(Frame& f, int side, double split, std::int32_t child, const AdtBox& domain) {
    const int a = static_cast<int>(f.k);
    if (side == 0)
        f.hi[f.k] = split < domain.hi[a] ? split : infinity;
    else
        f.lo[f.k] = split > domain.lo[a] ? split : -infinity;
    f.node = child;
    f.k = (f.k + 1) % K;
}

// squared_distance of a stored key (lo = key[0..2], hi = key[3..5]) to p; the same value.
inline double key_distance2(const double* key, const Eigen::Vector3d& p) {
    double d2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        const double d = std::max(std::max(key[a] - p[a], p[a] - key[a + 3]), 0.0);
        d2 += d * d;
    }
    return d2;
}

// The largest float <= x and the smallest float >= x (infinite beyond the float range), so a
// float box built from them contains the double box it stands for.
float float_below(double x) {
    constexpr double max_float = std::numeric_limits<float>::max();
    if (x > max_float) return std::numeric_limits<float>::max();
    if (!(x >= -max_float)) return -std::numeric_limits<float>::infinity();
    float f = static_cast<float>(x);
    if (static_cast<double>(f) > x) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
    return f;
}
float float_above(double x) {
    constexpr double max_float = std::numeric_limits<float>::max();
    if (x < -max_float) return -std::numeric_limits<float>::max();
    if (!(x <= max_float)) return std::numeric_limits<float>::infinity();
    float f = static_cast<float>(x);
    if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
    return f;
}

// Lower bound of squared_distance(item box, p) over the items of a subtree, from its stored
// bounds. The arithmetic mirrors key_distance2 term by term (the bounds enclose every item
// box, max is exact and rounding is monotone), so the bound never exceeds the computed
// distance of an item below and pruning with it is exact.
template <class Node>
double bound_distance2(const Node& n, const Eigen::Vector3d& p) {
    double d2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        const double d = std::max(std::max(static_cast<double>(n.bound_lo[a]) - p[a],
                                           p[a] - static_cast<double>(n.bound_hi[a])),
                                  0.0);
        d2 += d * d;
    }
    return d2;
}

// Depth-first walk over the subtrees whose stored bounds `meets` accepts; `visit(node)` runs
// on the node of every such subtree. The walk goes on into the first child in place and
// leaves the second on a per-thread stack (at most one entry per level), so concurrent const
// queries share nothing and a query allocates only while the stack outgrows its past depth.
template <class Nodes, class Meets, class Visit>
void bounded_walk(const Nodes& nodes, std::int32_t root, Meets&& meets, Visit&& visit) {
    if (root < 0 || !meets(nodes[static_cast<std::size_t>(root)])) return;
    thread_local std::vector<std::int32_t> stack;
    stack.clear();
    std::int32_t node = root;
    while (true) {
        const auto& n = nodes[static_cast<std::size_t>(node)];
        visit(n);
        const std::int32_t c0 = n.child[0];
        const std::int32_t c1 = n.child[1];
        if (c1 >= 0 && meets(nodes[static_cast<std::size_t>(c1)])) stack.push_back(c1);
        if (c0 >= 0 && meets(nodes[static_cast<std::size_t>(c0)])) {
            node = c0;
            continue;
        }
        if (stack.empty()) return;
        node = stack.back();
        stack.pop_back();
    }
}

bool has_nan(const Eigen::Vector3d& v) { return v.array().isNaN().any(); }

}  // namespace

Adt::Adt(const AdtBox& domain, AdtItems items)
    : domain_(domain), items_(items) {
    static_assert(sizeof(Node) == 88, "the node size is documented in adt.h");
    if (!domain.is_valid())
        FM_THROW(InputError, "ADT: root domain must be finite with lo <= hi on every axis");
}

std::int32_t Adt::allocate_node() {
    if (free_head_ >= 0) {
        const std::int32_t node = free_head_;
        free_head_ = nodes_[static_cast<std::size_t>(node)].child[0];
        return node;
    }
    FM_CHECK(nodes_.size() < static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()));
    nodes_.emplace_back();
    return static_cast<std::int32_t>(nodes_.size() - 1);
}

void Adt::insert(std::int32_t id, const Eigen::Vector3d& p) {
    if (!p.allFinite())
        FM_THROW(InputError, "ADT: point of item " + std::to_string(id) + " is not finite");
    insert(id, AdtBox::of_point(p));
}

void Adt::insert(std::int32_t id, const AdtBox& box) {
    FM_CHECK(id >= 0);
    FM_CHECK(!contains(id));
    if (!box.is_valid())
        FM_THROW(InputError, "ADT: box of item " + std::to_string(id) +
                                 " is not finite or has lo > hi on some axis");
    FM_CHECK(items_ == AdtItems::boxes || box.lo == box.hi);

    const std::int32_t node = allocate_node();
    Node& n = nodes_[static_cast<std::size_t>(node)];
    for (int a = 0; a < 3; ++a) {
        n.key[a] = box.lo[a];
        n.key[a + 3] = box.hi[a];
        n.bound_lo[a] = float_below(box.lo[a]);
        n.bound_hi[a] = float_above(box.hi[a]);
    }
    n.id = id;
    n.parent = -1;
    n.child[0] = n.child[1] = -1;
    if (static_cast<std::size_t>(id) >= node_of_id_.size())
        node_of_id_.resize(static_cast<std::size_t>(id) + 1, -1);
    node_of_id_[static_cast<std::size_t>(id)] = node;
    ++size_;

    insert_key(node);
}

// Bonet & Peraire: descend from the root bisecting the region in key coordinate depth mod K
// and hang the node at the first empty child. Keys outside the domain are clamped onto it.
// Every node on the way gets its subtree bounds widened to the new item's.
void Adt::insert_key(std::int32_t node) {
    if (root_ < 0) {
        root_ = node;
        return;
    }
    const Node& item = nodes_[static_cast<std::size_t>(node)];
    const float item_lo[3] = {item.bound_lo[0], item.bound_lo[1], item.bound_lo[2]};
    const float item_hi[3] = {item.bound_hi[0], item.bound_hi[1], item.bound_hi[2]};
    double key[K];
    for (int k = 0; k < K; ++k)
        key[k] = std::clamp(item.key[k], domain_.lo[k], domain_.hi[k]);
    Frame f = root_frame(root_);
    while (true) {
        const double split = split_value(f, domain_);
        const int side = key[f.k] < split ? 0 : 1;
        Node& parent = nodes_[static_cast<std::size_t>(f.node)];
        for (int a = 0; a < 3; ++a) {  // written only when they grow: fewer dirty lines
            if (item_lo[a] < parent.bound_lo[a]) parent.bound_lo[a] = item_lo[a];
            if (item_hi[a] > parent.bound_hi[a]) parent.bound_hi[a] = item_hi[a];
        }
        if (parent.child[side] < 0) {
            parent.child[side] = node;
            nodes_[static_cast<std::size_t>(node)].parent = f.node;
            return;
        }
        descend(f, side, split, parent.child[side], domain_);
    }
}

bool Adt::remove(std::int32_t id) {
    if (!contains(id)) return false;
    const std::int32_t node = node_of_id_[static_cast<std::size_t>(id)];
    node_of_id_[static_cast<std::size_t>(id)] = -1;

    // A leaf below `node` lies in a sub-region of node's region, so its item may move up.
    std::int32_t leaf = node;
    while (true) {
        const Node& l = nodes_[static_cast<std::size_t>(leaf)];
        if (l.child[0] >= 0)
            leaf = l.child[0];
        else if (l.child[1] >= 0)
            leaf = l.child[1];
        else
            break;
    }
    if (leaf != node) {
        Node& target = nodes_[static_cast<std::size_t>(node)];
        const Node& source = nodes_[static_cast<std::size_t>(leaf)];
        std::copy(source.key, source.key + 6, target.key);
        target.id = source.id;
        node_of_id_[static_cast<std::size_t>(target.id)] = node;
    }

    Node& l = nodes_[static_cast<std::size_t>(leaf)];
    if (l.parent < 0) {
        root_ = -1;
    } else {
        Node& parent = nodes_[static_cast<std::size_t>(l.parent)];
        parent.child[parent.child[0] == leaf ? 0 : 1] = -1;
    }
    l.id = -1;
    l.parent = -1;
    l.child[0] = free_head_;
    l.child[1] = -1;
    free_head_ = leaf;
    --size_;
    // The subtree bounds on the path are left as they are: they still enclose every item
    // below, only more loosely; compact() makes them exact again.
    return true;
}

AdtBox Adt::box(std::int32_t id) const {
    FM_CHECK(contains(id));
    const Node& n = nodes_[static_cast<std::size_t>(node_of_id_[static_cast<std::size_t>(id)])];
    return {Eigen::Vector3d(n.key[0], n.key[1], n.key[2]),
            Eigen::Vector3d(n.key[3], n.key[4], n.key[5])};
}

void Adt::clear() {
    nodes_.clear();
    node_of_id_.clear();
    root_ = -1;
    free_head_ = -1;
    size_ = 0;
}

void Adt::reserve(std::int32_t items) {
    if (items <= 0) return;
    nodes_.reserve(static_cast<std::size_t>(items));
    node_of_id_.reserve(static_cast<std::size_t>(items));
}

void Adt::compact() {
    std::vector<Node> ordered;
    ordered.reserve(static_cast<std::size_t>(size_));
    std::vector<std::int32_t> new_index(nodes_.size(), -1);
    // Pre-order with the first child next to its parent: a subtree occupies one index range.
    std::vector<std::int32_t> stack;
    if (root_ >= 0) stack.push_back(root_);
    while (!stack.empty()) {
        const std::int32_t node = stack.back();
        stack.pop_back();
        new_index[static_cast<std::size_t>(node)] = static_cast<std::int32_t>(ordered.size());
        const Node& n = nodes_[static_cast<std::size_t>(node)];
        ordered.push_back(n);
        if (n.child[1] >= 0) stack.push_back(n.child[1]);
        if (n.child[0] >= 0) stack.push_back(n.child[0]);
    }
    for (Node& n : ordered) {
        if (n.parent >= 0) n.parent = new_index[static_cast<std::size_t>(n.parent)];
        for (std::int32_t& c : n.child)
            if (c >= 0) c = new_index[static_cast<std::size_t>(c)];
        node_of_id_[static_cast<std::size_t>(n.id)] =
            new_index[static_cast<std::size_t>(node_of_id_[static_cast<std::size_t>(n.id)])];
    }
    nodes_ = std::move(ordered);
    root_ = nodes_.empty() ? -1 : 0;
    free_head_ = -1;
    // Exact subtree bounds: in pre-order every child comes after its parent.
    for (std::size_t i = nodes_.size(); i-- > 0;) {
        Node& n = nodes_[i];
        for (int a = 0; a < 3; ++a) {
            n.bound_lo[a] = float_below(n.key[a]);
            n.bound_hi[a] = float_above(n.key[a + 3]);
        }
        for (const std::int32_t child : n.child) {
            if (child < 0) continue;
            const Node& c = nodes_[static_cast<std::size_t>(child)];
            for (int a = 0; a < 3; ++a) {
                n.bound_lo[a] = std::min(n.bound_lo[a], c.bound_lo[a]);
                n.bound_hi[a] = std::max(n.bound_hi[a], c.bound_hi[a]);
            }
        }
    }
}

void Adt::collect_box(const AdtBox& query, std::vector<std::int32_t>& out_ids) const {
    // A subtree is skipped when its bounds miss the query; the items of the rest are tested.
    auto meets = [&](const Node& n) {
        return n.bound_lo[0] <= query.hi[0] && n.bound_lo[1] <= query.hi[1] &&
               n.bound_lo[2] <= query.hi[2] && n.bound_hi[0] >= query.lo[0] &&
               n.bound_hi[1] >= query.lo[1] && n.bound_hi[2] >= query.lo[2];
    };
    auto visit = [&](const Node& n) {
        if (n.key[0] <= query.hi[0] && n.key[1] <= query.hi[1] && n.key[2] <= query.hi[2] &&
            n.key[3] >= query.lo[0] && n.key[4] >= query.lo[1] && n.key[5] >= query.lo[2])
            out_ids.push_back(n.id);
    };
    bounded_walk(nodes_, root_, meets, visit);
}

void Adt::query_box(const AdtBox& query, std::vector<std::int32_t>& out_ids, AdtOrder order) const {
    out_ids.clear();
    if (has_nan(query.lo) || has_nan(query.hi))
        FM_THROW(InputError, "ADT: query box has a NaN coordinate");
    if ((query.lo.array() > query.hi.array()).any()) return;
    collect_box(query, out_ids);
    if (order == AdtOrder::by_id) std::sort(out_ids.begin(), out_ids.end());
}

void Adt::collect_sphere(const Eigen::Vector3d& center, double radius2,
                         std::vector<std::int32_t>& out_ids) const {
    auto meets = [&](const Node& n) { return bound_distance2(n, center) <= radius2; };
    auto visit = [&](const Node& n) {
        if (key_distance2(n.key, center) <= radius2) out_ids.push_back(n.id);
    };
    bounded_walk(nodes_, root_, meets, visit);
}

void Adt::query_sphere(const Eigen::Vector3d& center, double radius,
                       std::vector<std::int32_t>& out_ids, AdtOrder order) const {
    out_ids.clear();
    if (!center.allFinite() || std::isnan(radius))
        FM_THROW(InputError, "ADT: sphere query has a non-finite centre or a NaN radius");
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
        const AdtNeighbor candidate{n.id, key_distance2(n.key, p)};
        if (heap.size() < k) {
            heap.push_back(candidate);
            std::push_heap(heap.begin(), heap.end(), closer);
        } else if (closer(candidate, heap.front())) {
            std::pop_heap(heap.begin(), heap.end(), closer);
            heap.back() = candidate;
            std::push_heap(heap.begin(), heap.end(), closer);
        }

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
        bool has_next = count > 0;
        if (has_next) node = next[0].node;
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
    if (!p.allFinite()) FM_THROW(InputError, "ADT: nearest query point is not finite");
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
