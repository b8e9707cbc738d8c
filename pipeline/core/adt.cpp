#include "pipeline/core/adt.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <emmintrin.h>
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

// The float next to the finite float f towards -infinity (down) or +infinity (up), as
// std::nextafter gives it, from its bits: the libm call was a tenth of an insertion.
inline float float_step(float f, bool up) {
    if (f == 0.0f) return up ? std::numeric_limits<float>::denorm_min()
                             : -std::numeric_limits<float>::denorm_min();
    std::uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    // Away from zero the magnitude grows (bits + 1), towards zero it shrinks (bits - 1).
    bits += ((f > 0.0f) == up) ? 1u : static_cast<std::uint32_t>(-1);
    std::memcpy(&f, &bits, sizeof f);
    return f;
}

// The largest float <= x and the smallest float >= x (infinite beyond the float range), so a
// float box built from them contains the double box it stands for.
inline float float_below(double x) {
    constexpr double max_float = std::numeric_limits<float>::max();
    if (x > max_float) return std::numeric_limits<float>::max();
    if (!(x >= -max_float)) return -std::numeric_limits<float>::infinity();
    const float f = static_cast<float>(x);
    return static_cast<double>(f) > x ? float_step(f, false) : f;
}
inline float float_above(double x) {
    constexpr double max_float = std::numeric_limits<float>::max();
    if (x < -max_float) return -std::numeric_limits<float>::max();
    if (!(x <= max_float)) return std::numeric_limits<float>::infinity();
    const float f = static_cast<float>(x);
    return static_cast<double>(f) < x ? float_step(f, true) : f;
}

// The stored bounds of an item box: lo rounded down, -(hi rounded up), as Node::bound.
void set_bound(float* bound, const double* lo, const double* hi) {
    for (int a = 0; a < 3; ++a) {
        bound[a] = float_below(lo[a]);
        bound[a + 3] = -float_above(hi[a]);
    }
}

// bound := min(bound, item) elementwise (the union of the two boxes); stored only when it
// grows, which leaves fewer dirty cache lines on the insertion path. The two 4-float halves
// overlap in elements 2 and 3, on which they agree.
inline void widen_bound(float* bound, const float* item) {
    const __m128 a = _mm_loadu_ps(bound), b = _mm_loadu_ps(bound + 2);
    const __m128 ia = _mm_loadu_ps(item), ib = _mm_loadu_ps(item + 2);
    if (_mm_movemask_ps(_mm_or_ps(_mm_cmplt_ps(ia, a), _mm_cmplt_ps(ib, b))) == 0) return;
    _mm_storeu_ps(bound + 2, _mm_min_ps(b, ib));
    _mm_storeu_ps(bound, _mm_min_ps(a, ia));
}

// A box query in the form of Node::bound: the bounds (lo, -hi) meet the closed query box when
// lo <= query hi and -hi <= -query lo on every axis, i.e. (lo x, y, z, -hi x) <= q0 and
// (lo z, -hi x, y, z) <= q1 elementwise.
struct BoxTest {
    __m128 q0, q1;
    BoxTest(const float* qlo, const float* qhi)
        : q0(_mm_setr_ps(qhi[0], qhi[1], qhi[2], -qlo[0])),
          q1(_mm_setr_ps(qhi[2], -qlo[0], -qlo[1], -qlo[2])) {}
    bool meets(const float* bound) const {
        const __m128 a = _mm_cmple_ps(_mm_loadu_ps(bound), q0);
        const __m128 b = _mm_cmple_ps(_mm_loadu_ps(bound + 2), q1);
        return _mm_movemask_ps(_mm_and_ps(a, b)) == 0xF;
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
        const double d = std::max(std::max(static_cast<double>(n.bound[a]) - p[a],
                                           p[a] + static_cast<double>(n.bound[a + 3])),
                                  0.0);
        d2 += d * d;
    }
    return d2;
}

// Depth-first walk over the subtrees whose stored bounds `meets` accepts; `visit(node)` runs
// on the node of every such subtree, in pre-order (node, first child's subtree, second
// child's subtree), which pruning never reorders. The walk goes on into the first child in
// place and leaves the second on a per-thread stack (at most one entry per level), so
// concurrent const queries share nothing and a query allocates only while the stack
// outgrows its past depth.
template <class Nodes, class Meets, class Visit>
void bounded_walk(const Nodes& nodes, std::int32_t root, Meets&& meets, Visit&& visit) {
    if (root < 0 || !meets(nodes[static_cast<std::size_t>(root)])) return;
    thread_local std::vector<std::int32_t> stack(64);
    std::int32_t* top = stack.data();  // next free entry
    std::int32_t* end = top + stack.size();
    std::int32_t node = root;
    while (true) {
        const auto& n = nodes[static_cast<std::size_t>(node)];
        visit(n);
        const std::int32_t c0 = n.child[0];
        const std::int32_t c1 = n.child[1];
        if (c1 >= 0 && meets(nodes[static_cast<std::size_t>(c1)])) {
            if (top == end) {  // deeper than ever before on this thread
                const std::size_t used = static_cast<std::size_t>(top - stack.data());
                stack.resize(2 * stack.size());
                top = stack.data() + used;
                end = stack.data() + stack.size();
            }
            *top++ = c1;
        }
        if (c0 >= 0 && meets(nodes[static_cast<std::size_t>(c0)])) {
            node = c0;
            continue;
        }
        if (top == stack.data()) return;
        node = *--top;
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
    }
    set_bound(n.bound, n.key, n.key + 3);
    n.id = id;
    n.parent = -1;
    n.child[0] = n.child[1] = -1;
    if (static_cast<std::size_t>(id) >= node_of_id_.size())
        node_of_id_.resize(static_cast<std::size_t>(id) + 1, -1);
    node_of_id_[static_cast<std::size_t>(id)] = node;
    ++size_;

    insert_key(node);
}

// Bonet & Peraire: descend from the root bisecting the node's region of key space in key
// coordinate depth mod 3 (an item's key is the low corner of its box, the point itself for
// points) and hang the node at the first empty child. Keys outside the domain
// are clamped onto it to choose a branch. The region starts as the domain and each level
// halves it at split = 0.5 lo + 0.5 hi, which lies in [lo, hi]. Every node on the way gets
// its subtree bounds widened to the new item's.
void Adt::insert_key(std::int32_t node) {
    if (root_ < 0) {
        root_ = node;
        return;
    }
    Node* const pool = nodes_.data();
    float item_bound[6];
    std::copy(pool[node].bound, pool[node].bound + 6, item_bound);
    const double* key = pool[node].key;
    const double kx = std::clamp(key[0], domain_.lo[0], domain_.hi[0]);
    const double ky = std::clamp(key[1], domain_.lo[1], domain_.hi[1]);
    const double kz = std::clamp(key[2], domain_.lo[2], domain_.hi[2]);
    double lx = domain_.lo[0], hx = domain_.hi[0], ly = domain_.lo[1], hy = domain_.hi[1];
    double lz = domain_.lo[2], hz = domain_.hi[2];
    std::int32_t at = root_;
    // One level on one axis: true when the node was hung there. The axes x, y, z follow one
    // another in the unrolled loop below; the region bounds stay in registers.
    auto level = [&](double k, double& lo, double& hi) {
        const double split = 0.5 * lo + 0.5 * hi;
        const int side = k < split ? 0 : 1;
        Node& parent = pool[at];
        widen_bound(parent.bound, item_bound);
        const std::int32_t child = parent.child[side];
        if (child < 0) {
            parent.child[side] = node;
            pool[node].parent = at;
            return true;
        }
        (side == 0 ? hi : lo) = split;
        at = child;
        return false;
    };
    while (!level(kx, lx, hx) && !level(ky, ly, hy) && !level(kz, lz, hz)) {
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
    HugeVector<Node> ordered;
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
        set_bound(n.bound, n.key, n.key + 3);
        for (const std::int32_t child : n.child)
            if (child >= 0) widen_bound(n.bound, nodes_[static_cast<std::size_t>(child)].bound);
    }
}

void Adt::collect_box(const AdtBox& query, std::vector<std::int32_t>& out_ids) const {
    // A subtree is skipped when its bounds miss the query; the items of the rest are tested.
    // The bounds are floats: compared with the query rounded outward to floats, a subtree is
    // skipped only when its bounds miss the exact query too (visiting more never changes the
    // result, whose order is the fixed pre-order of the tree).
    float qlo[3], qhi[3];
    for (int a = 0; a < 3; ++a) {
        qlo[a] = float_below(query.lo[a]);
        qhi[a] = float_above(query.hi[a]);
    }
    const BoxTest test(qlo, qhi);
    auto meets = [&](const Node& n) { return test.meets(n.bound); };
    // The item's exact box (key) against the query, in doubles, two axes at a time:
    // (lo x, lo y) <= (hi x, hi y) of the query, (lo z, query lo x) <= (query hi z, hi x),
    // (query lo y, query lo z) <= (hi y, hi z).
    const __m128d qhi01 = _mm_loadu_pd(query.hi.data());
    const __m128d qhi2 = _mm_set_sd(query.hi[2]);
    const __m128d qlo0 = _mm_set1_pd(query.lo[0]);
    const __m128d qlo12 = _mm_loadu_pd(query.lo.data() + 1);
    auto visit = [&](const Node& n) {
        const __m128d k23 = _mm_loadu_pd(n.key + 2);
        const __m128d m0 = _mm_cmple_pd(_mm_loadu_pd(n.key), qhi01);
        const __m128d m1 = _mm_cmple_pd(_mm_move_sd(qlo0, k23), _mm_move_sd(k23, qhi2));
        const __m128d m2 = _mm_cmple_pd(qlo12, _mm_loadu_pd(n.key + 4));
        if (_mm_movemask_pd(_mm_and_pd(_mm_and_pd(m0, m1), m2)) == 3) out_ids.push_back(n.id);
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
    // bounds (lo x, y, z, -hi x, y, z) as floats
    double bound_distance2(const float* b) const {
        const __m128 b0 = _mm_loadu_ps(b), b1 = _mm_loadu_ps(b + 2);
        const __m128d lo01 = _mm_cvtps_pd(b0);
        const __m128d nhi01 = _mm_cvtps_pd(_mm_shuffle_ps(b1, b1, _MM_SHUFFLE(3, 3, 2, 1)));
        return finish(_mm_sub_pd(lo01, p01), _mm_add_pd(p01, nhi01),
                      static_cast<double>(b[2]) - p2, p2 + static_cast<double>(b[5]));
    }
    // key (lo x, y, z, hi x, y, z) as doubles
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
    auto visit = [&](const Node& n) {
        if (test.key_distance2(n.key) <= radius2) out_ids.push_back(n.id);
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
