#pragma once
// The front of tetra's layered advancing front (§3.1.1: "triangle on the front: 3 nodes; unit
// normal vector", "node on the front: connected triangles", "ADT: nodes on the front"), and
// the queue of bases of §3.1.4 step 1. Internal to the tetra stage (volume/tetra.cpp).
//
// Memory per million front faces: 64 B record + 12 B back links + 1 B flag + about 100 B in
// the face ADT (leaf buckets half full or more); per million nodes 4 B list head + about
// 100 B in the node ADT while on the front.

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/adt.h"
#include "pipeline/core/huge_pages.h"
#include "pipeline/core/morton.h"

namespace frontmesh::volume {

using Tri = std::array<std::int32_t, 3>;

/// One front triangle, one cache line: what the search for a base and its tests read
/// together. Its normal points into the unmeshed part of the region.
struct alignas(64) FrontFace {
    Tri v;                 ///< nodes
    std::int32_t next[3];  ///< per corner: next corner 3 g + c in the node's list, -1
    double n[3];           ///< unit normal
    double area;
    std::int32_t stamp;   ///< generation, validates queue entries
    std::int32_t failed;  ///< generation at which the face last failed as a base, -1
};
static_assert(sizeof(FrontFace) == 64, "one cache line per front face");

/// Cyclic equality of the oriented triangles (a, b, c) and t.
inline bool same_cycle(const Tri& t, std::int32_t a, std::int32_t b, std::int32_t c) {
    return (t[0] == a && t[1] == b && t[2] == c) || (t[1] == a && t[2] == b && t[0] == c) ||
           (t[2] == a && t[0] == b && t[1] == c);
}

/// Morton code of p on a 2^21 grid over `box` (bits of x, y, z interleaved): nearby points get
/// nearby codes, mostly.
inline std::uint64_t morton_code(const Eigen::Vector3d& p, const core::AdtBox& box) {
    std::uint64_t code = 0;
    for (int a = 0; a < 3; ++a) {
        const double extent = box.hi[a] - box.lo[a];
        const double u = extent > 0.0 ? std::clamp((p[a] - box.lo[a]) / extent, 0.0, 1.0) : 0.0;
        code |= core::morton_spread21(static_cast<std::uint64_t>(u * 2097151.0)) << a;
    }
    return code;
}

/// The front triangles of one region with what the method asks of them: the faces at a node
/// (a list through the face records' corners, unlinked in O(1)), the face with given nodes,
/// the front nodes in a box or sphere (an ADT of nodes) and the front faces whose boxes meet a
/// box (an ADT of face boxes), and a bound on the longest front edge. Face ids are recycled.
class Front {
public:
    /// An empty front over the node coordinates `xyz` (3 per node, mm; the caller appends
    /// nodes and calls add_node for each); both ADTs take `domain` as their root region.
    Front(const core::HugeVector<double>& xyz, const core::AdtBox& domain);

    /// Node ids [0, n) exist: the node just appended to `xyz` (not yet on the front).
    void add_node() { face_head_.push_back(-1); }
    /// Forgets the last node, which has no front face.
    void pop_node() { face_head_.pop_back(); }

    /// Adds the face (a, b, c) (normal by the right-hand rule); its nodes join the node ADT
    /// when they were not on the front. Returns its id.
    std::int32_t add_face(std::int32_t a, std::int32_t b, std::int32_t c);
    /// Removes face f in O(1) (besides the ADT removals); nodes left without faces leave the
    /// node ADT.
    void remove_face(std::int32_t f);

    /// The front face with vertex set {a, b, c}, -1 if none.
    std::int32_t find_face(std::int32_t a, std::int32_t b, std::int32_t c) const {
        for (std::int32_t k = face_head_[a]; k >= 0; k = next_corner(k)) {
            const Tri& t = faces_[k / 3].v;
            const bool hb = t[0] == b || t[1] == b || t[2] == b;
            const bool hc = t[0] == c || t[1] == c || t[2] == c;
            if (hb && hc) return k / 3;
        }
        return -1;
    }

    /// Number of faces on the front.
    std::int32_t size() const { return size_; }
    /// Face ids are below this; is_alive tells which are on the front.
    std::int32_t id_bound() const { return static_cast<std::int32_t>(faces_.size()); }
    bool is_alive(std::int32_t f) const { return falive_[f] != 0; }
    const FrontFace& face(std::int32_t f) const { return faces_[f]; }
    Eigen::Vector3d normal(std::int32_t f) const {
        return Eigen::Vector3d(faces_[f].n[0], faces_[f].n[1], faces_[f].n[2]);
    }
    /// The record array itself, indexed by face id, for the validity test.
    const FrontFace* records() const { return faces_.data(); }

    /// Remembers that face f failed as a base in its current generation.
    void mark_failed(std::int32_t f) { faces_[f].failed = faces_[f].stamp; }
    bool has_failed(std::int32_t f) const { return faces_[f].failed == faces_[f].stamp; }

    /// The corners (3 f + c: node v is corner c of face f) of the faces at node v:
    /// `for (k = first_corner(v); k >= 0; k = next_corner(k))`. -1 when v is not on the front.
    std::int32_t first_corner(std::int32_t v) const { return face_head_[v]; }
    std::int32_t next_corner(std::int32_t k) const { return faces_[k / 3].next[k % 3]; }

    /// Every front face whose box meets `box` (a superset of the faces touching it), in the
    /// tree's order: every user decides on the whole set.
    void faces_in_box(const core::AdtBox& box, std::vector<std::int32_t>& out) const {
        face_adt_.query_box(box, out, core::AdtOrder::walk);
    }
    /// The front nodes in `box`, in the tree's order.
    void nodes_in_box(const core::AdtBox& box, std::vector<std::int32_t>& out) const {
        node_adt_.query_box(box, out, core::AdtOrder::walk);
    }
    /// The front nodes in the closed ball (`center`, `radius`), in id order.
    void nodes_in_sphere(const Eigen::Vector3d& center, double radius,
                         std::vector<std::int32_t>& out) const {
        node_adt_.query_sphere(center, radius, out);
    }
    /// The root region of the ADTs.
    const core::AdtBox& domain() const { return node_adt_.domain(); }
    /// Tightens both ADTs after many changes (queries return the same sets).
    void compact() {
        node_adt_.compact();
        face_adt_.compact();
    }

    /// Upper bound (mm) of every front edge length.
    double max_edge() const;

private:
    Eigen::Vector3d x(std::int32_t v) const {
        const double* q = &xyz_[3 * static_cast<std::size_t>(v)];
        return Eigen::Vector3d(q[0], q[1], q[2]);
    }
    /// The bucket of an edge of squared length len2 (below).
    static int bucket_of(double len2);
    void count_edge(std::int32_t u, std::int32_t v, int delta);

    const core::HugeVector<double>& xyz_;
    core::HugeVector<FrontFace> faces_;
    core::HugeVector<std::uint8_t> falive_;
    core::HugeVector<std::int32_t> fprev_;      // per corner: previous corner in the node's list
    core::HugeVector<std::int32_t> face_head_;  // per node: first corner 3 f + c, -1
    std::vector<std::int32_t> free_faces_;
    std::int32_t size_ = 0;
    core::Adt node_adt_;  // the front nodes (§3.1.1)
    // The boxes of the front faces: the faces a test needs are exactly those whose box meets
    // the box of the tet (or segment), found without the node ADT's longest-edge margin.
    core::Adt face_adt_;
    // Front edge lengths in buckets of 2^(1/4) (each edge once per face), for a safe bound on
    // the longest front edge: it scales the rounding tolerance of the plane filter of the
    // validity test (a face meeting a box has its nodes in the box grown by that bound).
    static constexpr int kBuckets = 512;
    std::vector<std::int64_t> edge_bucket_ = std::vector<std::int64_t>(kBuckets, 0);
    int top_bucket_ = 0;
};

/// The bases waiting in a stage (§3.1.4 step 1), smallest (key, Morton code, face) first. Keys
/// are area classes (few distinct values) in the layered front and areas in the closing phase.
/// With classes, one binary heap per class: the same order as one heap over everything, and
/// each pop sifts through the small heap of the current class only.
class BaseQueue {
public:
    struct Item {
        double key;
        std::uint64_t morton;
        std::int32_t f, stamp;
    };
    explicit BaseQueue(bool by_class) : by_class_(by_class) {}
    void push(const Item& it) {
        std::vector<Item>& heap = by_class_ ? classes_[it.key] : flat_;
        heap.push_back(it);
        if (!bulk_) std::push_heap(heap.begin(), heap.end(), later);
    }
    /// Pushes between begin_bulk() and end_bulk() are ordered at end_bulk(), in O(n) instead
    /// of O(n log n); the pops that follow are the same (the order is total, and items equal
    /// in it are the same base).
    void begin_bulk() { bulk_ = true; }
    void end_bulk() {
        bulk_ = false;
        if (!by_class_) std::make_heap(flat_.begin(), flat_.end(), later);
        for (auto& [key, heap] : classes_) std::make_heap(heap.begin(), heap.end(), later);
    }
    bool empty() const { return by_class_ ? classes_.empty() : flat_.empty(); }
    Item pop() {
        std::vector<Item>& heap = by_class_ ? classes_.begin()->second : flat_;
        std::pop_heap(heap.begin(), heap.end(), later);
        const Item it = heap.back();
        heap.pop_back();
        if (by_class_ && heap.empty()) classes_.erase(classes_.begin());
        return it;
    }

private:
    // heap order: the top is the smallest (key, morton, f); a function object, which the
    // heap algorithms inline (a function pointer they called: 2% of the stage)
    struct Later {
        bool operator()(const Item& a, const Item& b) const {
            if (a.key != b.key) return a.key > b.key;
            if (a.morton != b.morton) return a.morton > b.morton;
            return a.f > b.f;
        }
    };
    static constexpr Later later{};
    bool by_class_;
    bool bulk_ = false;
    std::vector<Item> flat_;
    std::map<double, std::vector<Item>> classes_;
};

}  // namespace frontmesh::volume
