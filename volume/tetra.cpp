#include "volume/tetra.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <queue>
#include <sstream>
#include <string>
#include <vector>

#include <emmintrin.h>
#include <tbb/parallel_for.h>

#include "pipeline/core/adt.h"
#include "pipeline/core/error.h"
#include "pipeline/core/huge_pages.h"
#include "pipeline/core/morton.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/quality.h"

namespace frontmesh::volume {

namespace {

using core::Label;
using V3 = Eigen::Vector3d;
using Tri = std::array<std::int32_t, 3>;
using Tet = std::array<std::int32_t, 4>;

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// Outward faces of a VTK-positive tet (v0, v1, v2, v3): the right-hand normal of each points
// away from the opposite vertex.
constexpr int kTetFace[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};

/// What one region's mesher hands back for the merge.
struct RegionResult {
    Label region = 0;
    std::int32_t boundary_nodes = 0;            // local ids [0, boundary_nodes) are surface ones
    std::vector<std::int32_t> global_of_local;  // for the boundary nodes
    std::vector<double> xyz;                    // every local node
    std::vector<std::int32_t> level;            // every local node
    std::vector<Tet> tets;                      // alive tets, local ids
    std::int64_t remeshes = 0;
    std::int64_t closing_rounds = 0;
    std::int64_t closing_tets = 0;
    std::int32_t levels = 0;
    std::int64_t stat[8] = {};  // see kStatNames
};

constexpr const char* kStatNames[8] = {"bases_tried",         "bases_failed",
                                       "candidates_rejected_by_tests", "candidates_invalid",
                                       "tets_on_existing_nodes", "tets_on_new_nodes",
                                       "stage1_tets",         "stage2_tets"};

/// Morton code of p on a 2^21 grid over `box` (bits of x, y, z interleaved): nearby points get
/// nearby codes, mostly.
std::uint64_t morton_code(const V3& p, const core::AdtBox& box) {
    std::uint64_t code = 0;
    for (int a = 0; a < 3; ++a) {
        const double extent = box.hi[a] - box.lo[a];
        const double u = extent > 0.0 ? std::clamp((p[a] - box.lo[a]) / extent, 0.0, 1.0) : 0.0;
        code |= core::morton_spread21(static_cast<std::uint64_t>(u * 2097151.0)) << a;
    }
    return code;
}

/// Cyclic equality of the oriented triangles (a, b, c) and t.
bool same_cycle(const Tri& t, std::int32_t a, std::int32_t b, std::int32_t c) {
    return (t[0] == a && t[1] == b && t[2] == c) || (t[1] == a && t[2] == b && t[0] == c) ||
           (t[2] == a && t[0] == b && t[1] == c);
}

/// The bases waiting in a stage, smallest (key, Morton code, face) first. Keys are area
/// classes (few distinct values) in the layered front and areas in the closing phase. With
/// classes, one binary heap per class: the same order as one heap over everything, and each
/// pop sifts through the small heap of the current class only.
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

/// The layered advancing front of §3.1-3.2 for one region.
///
/// Memory per million elements: nodes 24 B xyz + 60 B attributes + about 100 B in the node ADT
/// while on the front; front faces 77 B (a 64-B record, back links, a flag) + about 100 B in
/// the face ADT (leaf buckets half full or more); tets 16 B + 16 B links + 5 B. About 0.1 GB
/// per million tets in all (Colin27: 557k tets, 132 MB peak for the whole run).
class RegionMesher {
public:
    using Log = std::function<void(const std::string&)>;
    RegionMesher(const core::SurfaceNetwork& surface, Label region, const TetraParams& params,
                 Log log)
        : log_(std::move(log)), params_(params), region_(region), adt_(domain_of(surface, region), core::AdtItems::points),
          face_adt_(domain_of(surface, region), core::AdtItems::boxes) {
        init_front(surface);
    }

    RegionResult run();

private:
    Log log_;
    // ---- §3.1.1 required data ------------------------------------------------------------
    const TetraParams params_;
    const Label region_;
    const double sin_min_ = std::sin(params_.min_angle_deg * kDegToRad);  // step 4 angle tests
    const double cos_min_ = std::cos(params_.min_angle_deg * kDegToRad);
    const double sin2_min_ = sin_min_ * sin_min_, cos2_min_ = cos_min_ * cos_min_;
    std::int32_t boundary_nodes_ = 0;
    std::vector<std::int32_t> global_of_local_;

    // nodes (flat, int32 ids)
    core::HugeVector<double> xyz_;
    core::HugeVector<std::int32_t> level_;         // front level at creation + 1 (0 = surface)
    core::HugeVector<std::int32_t> setup_stamp_;   // last front number that set this node up, -1
    core::HugeVector<double> normal_;              // Eq. 3, 3 per node
    core::HugeVector<double> h_;                   // h'_o of Eq. 6 (smoothed), 0 = never set
    core::HugeVector<double> rs_;                  // r'_s of Eq. 7
    core::HugeVector<std::int32_t> remesh_count_;  // §3.2
    core::HugeVector<std::int32_t> face_head_;     // first corner 3 f + c of the node's front faces
    core::HugeVector<std::int32_t> tet_head_;      // first corner 4 t + c of the node's tets
    core::HugeVector<std::int32_t> mark_;          // scratch stamps
    std::int32_t mark_value_ = 0;
    struct NodeCode {
        std::int32_t stamp;   // valid when it is the call's stamp
        std::uint16_t code;
    };
    core::HugeVector<NodeCode> node_code_;         // is_valid_tet's per-node codes
    std::int32_t code_stamp_value_ = 0;

    // front triangles (normal points into the unmeshed part of the region)
    // One cache line per face: what the search for a base and its tests read together.
    struct alignas(64) FaceRec {
        Tri v;                    // nodes
        std::int32_t next[3];     // per corner: next corner 3 g + c in the node's list, -1
        double n[3];              // unit normal
        double area;
        std::int32_t stamp;       // generation, validates queue entries
        std::int32_t failed;      // generation at which the face last failed, -1
    };
    static_assert(sizeof(FaceRec) == 64, "one cache line per front face");
    core::HugeVector<FaceRec> faces_;
    core::HugeVector<std::uint8_t> falive_;
    core::HugeVector<std::int32_t> fprev_;        // per corner: previous corner in the node's list, -1
    std::vector<std::int32_t> free_faces_;
    std::int32_t front_size_ = 0;
    core::Adt adt_;                           // the front nodes (§3.1.1)
    // The boxes of the front faces: the faces a test needs are exactly those whose box meets
    // the box of the tet (or segment), found without the node ADT's longest-edge margin.
    core::Adt face_adt_;
    // Front edge lengths in buckets of 2^(1/4) (each edge once per face), for a safe bound on
    // the longest front edge: it scales the rounding tolerance of the plane filter of
    // is_valid_tet (a face meeting a box has its nodes in the box grown by that bound).
    static constexpr int kBuckets = 512;
    std::vector<std::int64_t> edge_bucket_ = std::vector<std::int64_t>(kBuckets, 0);
    int top_bucket_ = 0;

    // tetrahedra
    core::HugeVector<Tet> tv_;
    core::HugeVector<std::int32_t> tnext_;         // 4 per tet
    core::HugeVector<std::int32_t> tfront_;        // front number at creation
    core::HugeVector<std::uint8_t> talive_;
    std::int64_t alive_tets_ = 0;

    // run state
    std::int32_t front_no_ = 0;
    std::int64_t remeshes_ = 0;
    std::int64_t remesh_budget_ = 0;
    std::vector<std::int32_t> new_faces_;     // faces added by the last add/remove
    std::vector<std::int32_t> visible_faces_;
    std::vector<std::int32_t> near_faces_;    // front faces of the current base's search box
    std::vector<std::int32_t> node_ids_;      // scratch: ADT query results
    struct Cand {
        double key0, key1;
        std::int32_t id;
    };
    std::vector<Cand> cands_;                 // candidates of the current base
    struct Suspect {
        std::int32_t f;
        std::uint16_t code[3];  // is_valid_tet's codes of its nodes
    };
    std::vector<Suspect> suspects_;           // is_valid_tet: faces past the filters
    std::int64_t stat_[8] = {};

    // ---- small helpers --------------------------------------------------------------------
    static core::AdtBox domain_of(const core::SurfaceNetwork& s, Label r) {
        core::AdtBox box;
        for (std::size_t f = 0; f < s.face_count(); ++f) {
            if (s.region_in[f] != r && s.region_out[f] != r) continue;
            for (std::int32_t v : s.faces[f]) box.extend(s.point(v));
        }
        if (!box.is_valid()) box = core::AdtBox::of_point(V3::Zero());
        const double d = (box.hi - box.lo).norm();
        return box.enlarged(0.05 * d + 1e-9);
    }
    const double* p(std::int32_t v) const { return &xyz_[3 * static_cast<std::size_t>(v)]; }
    V3 x(std::int32_t v) const { return V3(p(v)[0], p(v)[1], p(v)[2]); }
    V3 face_normal(std::int32_t f) const {
        return V3(faces_[f].n[0], faces_[f].n[1], faces_[f].n[2]);
    }
    V3 node_normal(std::int32_t v) const { return V3(normal_[3 * v], normal_[3 * v + 1], normal_[3 * v + 2]); }
    std::int32_t node_count() const { return static_cast<std::int32_t>(level_.size()); }
    std::int32_t next_code_stamp() {
        if (++code_stamp_value_ == std::numeric_limits<std::int32_t>::max()) {
            for (NodeCode& c : node_code_) c.stamp = 0;
            code_stamp_value_ = 1;
        }
        return code_stamp_value_;
    }
    std::int32_t next_mark() {
        if (++mark_value_ == std::numeric_limits<std::int32_t>::max()) {
            std::fill(mark_.begin(), mark_.end(), 0);
            mark_value_ = 1;
        }
        return mark_value_;
    }
    std::string where(std::int32_t v) const {
        std::ostringstream s;
        s.precision(6);
        s << "(" << p(v)[0] << ", " << p(v)[1] << ", " << p(v)[2] << ") mm";
        return s.str();
    }

    std::int32_t push_node(const V3& q, std::int32_t level) {
        xyz_.insert(xyz_.end(), {q.x(), q.y(), q.z()});
        level_.push_back(level);
        setup_stamp_.push_back(-1);
        normal_.insert(normal_.end(), {0.0, 0.0, 0.0});
        h_.push_back(0.0);
        rs_.push_back(0.0);
        remesh_count_.push_back(0);
        face_head_.push_back(-1);
        tet_head_.push_back(-1);
        mark_.push_back(0);
        node_code_.push_back({0, 0});
        return node_count() - 1;
    }
    void pop_node() {
        xyz_.resize(xyz_.size() - 3);
        level_.pop_back();
        setup_stamp_.pop_back();
        normal_.resize(normal_.size() - 3);
        h_.pop_back();
        rs_.pop_back();
        remesh_count_.pop_back();
        face_head_.pop_back();
        tet_head_.pop_back();
        mark_.pop_back();
        node_code_.pop_back();
    }

    // ---- front edge length bound and face gathering ---------------------------------------
    /// floor(4 log2 len) + kBuckets / 2, clamped, from len^2 = m 2^e (m in [0.5, 1)) without a
    /// logarithm: 4 log2 len = 2 e + 2 log2 m, whose floor is 2 e - 1 for m >= 2^(-1/2) and
    /// 2 e - 2 below. A length in bucket b is below 2^((b + 1 - kBuckets / 2) / 4).
    static int bucket_of(double len2) {
        if (!(len2 > 0.0)) return 0;
        if (!(len2 < std::numeric_limits<double>::infinity())) return kBuckets - 1;
        // m and e as std::frexp gives them, from the bits of a normal len2 (the libm call was
        // a tenth of a front face update)
        std::uint64_t bits;
        std::memcpy(&bits, &len2, sizeof bits);
        const int biased = static_cast<int>(bits >> 52);  // sign bit 0
        int e = biased - 1022;
        double m;
        if (biased != 0) {
            bits = (bits & ((std::uint64_t{1} << 52) - 1)) | (std::uint64_t{1022} << 52);
            std::memcpy(&m, &bits, sizeof m);
        } else {
            m = std::frexp(len2, &e);  // subnormal
        }
        const int b = 2 * e - (m >= 0.70710678118654752 ? 1 : 2) + kBuckets / 2;
        return std::clamp(b, 0, kBuckets - 1);
    }
    void count_edge(std::int32_t u, std::int32_t v, int delta) {
        const int b = bucket_of((x(u) - x(v)).squaredNorm());
        edge_bucket_[b] += delta;
        if (delta > 0) {
            top_bucket_ = std::max(top_bucket_, b);
        } else {
            while (top_bucket_ > 0 && edge_bucket_[top_bucket_] == 0) --top_bucket_;
        }
    }
    /// Upper bound (mm) of every front edge length.
    double max_front_edge() const {
        // per bucket, computed once for all meshers (read by every validity test)
        static const std::array<double, kBuckets> bound = [] {
            std::array<double, kBuckets> b{};
            for (int i = 0; i < kBuckets - 1; ++i) b[i] = std::exp2((i + 1 - kBuckets / 2) / 4.0) * 1.0001;
            b[kBuckets - 1] = std::numeric_limits<double>::infinity();
            return b;
        }();
        return bound[static_cast<std::size_t>(top_bucket_)];
    }
    /// Every front face whose box meets `box` (a superset of the faces touching it), from the
    /// ADT of front face boxes, in the tree's order: every user decides on the whole set.
    void gather_faces(const core::AdtBox& box, std::vector<std::int32_t>& out) const {
        face_adt_.query_box(box, out, core::AdtOrder::walk);
    }

    // ---- front faces ----------------------------------------------------------------------
    std::int32_t add_face(std::int32_t a, std::int32_t b, std::int32_t c) {
        std::int32_t f;
        if (!free_faces_.empty()) {
            f = free_faces_.back();
            free_faces_.pop_back();
        } else {
            f = static_cast<std::int32_t>(faces_.size());
            faces_.push_back({{0, 0, 0}, {-1, -1, -1}, {0.0, 0.0, 0.0}, 0.0, 0, -1});
            falive_.push_back(0);
            fprev_.insert(fprev_.end(), {-1, -1, -1});
        }
        faces_[f].v = {a, b, c};
        for (int k = 0; k < 3; ++k) count_edge(faces_[f].v[k], faces_[f].v[(k + 1) % 3], +1);
        const V3 n = (x(b) - x(a)).cross(x(c) - x(a));
        const double len = n.norm();
        faces_[f].area = 0.5 * len;
        const V3 u = len > 0.0 ? V3(n / len) : V3::Zero();
        faces_[f].n[0] = u.x();
        faces_[f].n[1] = u.y();
        faces_[f].n[2] = u.z();
        ++faces_[f].stamp;
        falive_[f] = 1;
        {
            core::AdtBox box;
            for (const std::int32_t v : {a, b, c}) box.extend(x(v));
            face_adt_.insert(f, box);
        }
        const Tri& t = faces_[f].v;
        for (int k = 0; k < 3; ++k) {
            if (face_head_[t[k]] < 0) adt_.insert(t[k], x(t[k]));  // joins the front
            const std::int32_t head = face_head_[t[k]];
            faces_[f].next[k] = head;
            fprev_[3 * f + k] = -1;
            if (head >= 0) fprev_[head] = 3 * f + k;
            face_head_[t[k]] = 3 * f + k;
        }
        ++front_size_;
        return f;
    }

    void remove_face(std::int32_t f) {
        const Tri t = faces_[f].v;
        for (int k = 0; k < 3; ++k) {
            const std::int32_t prev = fprev_[3 * f + k], next = faces_[f].next[k];
            (prev < 0 ? face_head_[t[k]] : faces_[prev / 3].next[prev % 3]) = next;
            if (next >= 0) fprev_[next] = prev;
            if (face_head_[t[k]] < 0) adt_.remove(t[k]);  // leaves the front
            count_edge(t[k], t[(k + 1) % 3], -1);
        }
        falive_[f] = 0;
        face_adt_.remove(f);
        ++faces_[f].stamp;
        free_faces_.push_back(f);
        --front_size_;
    }

    /// The front face with vertex set {a, b, c}, -1 if none.
    std::int32_t find_face(std::int32_t a, std::int32_t b, std::int32_t c) const {
        for (std::int32_t k = face_head_[a]; k >= 0; k = faces_[k / 3].next[k % 3]) {
            const Tri& t = faces_[k / 3].v;
            const bool hb = t[0] == b || t[1] == b || t[2] == b;
            const bool hc = t[0] == c || t[1] == c || t[2] == c;
            if (hb && hc) return k / 3;
        }
        return -1;
    }

    /// True when u-v is an edge of the front.
    bool is_front_edge(std::int32_t u, std::int32_t v) const {
        for (std::int32_t k = face_head_[u]; k >= 0; k = faces_[k / 3].next[k % 3]) {
            const Tri& t = faces_[k / 3].v;
            if (t[0] == v || t[1] == v || t[2] == v) return true;
        }
        return false;
    }

    /// One walk of the front faces at u: whether u-v is a front edge (is_front_edge) and
    /// whether a front face has the nodes {u, w, v} (find_face >= 0).
    void edge_and_face(std::int32_t u, std::int32_t w, std::int32_t v, bool& edge,
                       bool& face) const {
        edge = face = false;
        for (std::int32_t k = face_head_[u]; k >= 0; k = faces_[k / 3].next[k % 3]) {
            const Tri& t = faces_[k / 3].v;
            if (t[0] != v && t[1] != v && t[2] != v) continue;
            edge = true;
            if (t[0] == w || t[1] == w || t[2] == w) {
                face = true;
                return;
            }
        }
    }

    // ---- tets -----------------------------------------------------------------------------
    /// Adds the VTK-positive tet (a, b, c, d) and toggles its faces on the front (§3.1.4
    /// step 5): a face already on the front (pointing into the tet) leaves it, any other
    /// face joins it pointing away from the tet.
    void add_tet(std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t d) {
        const std::int32_t t = static_cast<std::int32_t>(tv_.size());
        tv_.push_back({a, b, c, d});
        tnext_.insert(tnext_.end(), {-1, -1, -1, -1});
        tfront_.push_back(front_no_);
        talive_.push_back(1);
        ++alive_tets_;
        const Tet& v = tv_[t];
        for (int k = 0; k < 4; ++k) {
            tnext_[4 * t + k] = tet_head_[v[k]];
            tet_head_[v[k]] = 4 * t + k;
        }
        new_faces_.clear();
        for (const auto& lf : kTetFace) {
            const std::int32_t x0 = v[lf[0]], x1 = v[lf[1]], x2 = v[lf[2]];
            const std::int32_t f = find_face(x0, x1, x2);
            if (f >= 0) {
                FM_CHECK(!same_cycle(faces_[f].v, x0, x1, x2));
                remove_face(f);
            } else {
                new_faces_.push_back(add_face(x0, x1, x2));
            }
        }
    }

    /// Removes tet t (§3.2): its faces toggle back.
    void remove_tet(std::int32_t t) {
        FM_CHECK(talive_[t]);
        talive_[t] = 0;
        --alive_tets_;
        const Tet v = tv_[t];
        for (const auto& lf : kTetFace) {
            const std::int32_t x0 = v[lf[0]], x1 = v[lf[1]], x2 = v[lf[2]];
            const std::int32_t f = find_face(x0, x1, x2);
            if (f >= 0) {
                FM_CHECK(same_cycle(faces_[f].v, x0, x1, x2));
                remove_face(f);
            } else {
                new_faces_.push_back(add_face(x0, x2, x1));
            }
        }
    }

    // ---- the base of a try (§3.1.4) --------------------------------------------------------
    /// One front face at a base node a_i, copied with what the tests of step 4 read: the
    /// face, its other two nodes u, w in cyclic order (the face is (a_i, u, w)), their
    /// positions and the unit normal. try_base copies the three stars once; every candidate's
    /// tests then read them from one small array instead of walking the node->face lists and
    /// the node and face arrays again (the front does not change before try_base returns).
    struct StarFace {
        std::int32_t f, u, w;
        V3 U, W, n;
    };
    struct Base {
        std::int32_t f = -1;
        std::int32_t a[3] = {-1, -1, -1};
        V3 A[3];
        V3 n;            // unit normal N_k
        double area = 0;  // a_k
        double h = 0;     // h_k, Eq. 8
        double eta = 0;   // Eq. 2
        V3 xm, xo, xc;    // centre, reference point, Eq. 11 centre
        double max_b = 0;  // max |x_ck B_ki|
        std::int32_t star_begin[4] = {0, 0, 0, 0};  // star of a_i: stars_[star_begin[i], [i + 1])
        std::int32_t wing_begin[4] = {0, 0, 0, 0};  // wings of edge a_i a_j: wings_[...]
        std::int32_t edge_begin[4] = {0, 0, 0, 0};  // front edges at a_i: edges_[...]
        V3 e[3];          // unit direction of the base edge a_i a_j (j = i + 1 mod 3)
    };
    std::vector<StarFace> stars_;  // the stars of the current base's nodes
    /// A front face on base edge a_i a_j other than the base: its third node and the part of
    /// (node - A_i) normal to the edge, for the dihedral angle test of new faces.
    struct Wing {
        std::int32_t v;
        V3 vp;
        double vpl2;
    };
    std::vector<Wing> wings_;
    /// A front edge (a_i, v) at a base node, for the edge-face angle test of new faces: v and
    /// the edge vector d = v - A_i with |d|^2 (every edge of the star once, or twice where a
    /// non-manifold star has it in two faces: the test's outcome is the same).
    struct EdgeAt {
        V3 d;
        double dl2;
        std::int32_t v;
    };
    std::vector<EdgeAt> edges_;

    // ---- exact validity (predicates decide) -----------------------------------------------
    /// True when the closed segment (s0, s1) meets the closed triangle (t0, t1, t2) anywhere
    /// but at their shared vertices. Exact.
    bool improper_intersection(std::int32_t s0, std::int32_t s1, std::int32_t t0, std::int32_t t1,
                               std::int32_t t2) const {
        const bool in0 = s0 == t0 || s0 == t1 || s0 == t2;
        const bool in1 = s1 == t0 || s1 == t1 || s1 == t2;
        if (in0 && in1) return false;
        if (!in0 && !in1) {
            for (int a = 0; a < 3; ++a) {  // cheap box rejection
                const double smin = std::min(p(s0)[a], p(s1)[a]);
                const double smax = std::max(p(s0)[a], p(s1)[a]);
                const double tmin = std::min({p(t0)[a], p(t1)[a], p(t2)[a]});
                const double tmax = std::max({p(t0)[a], p(t1)[a], p(t2)[a]});
                if (smax < tmin || smin > tmax) return false;
            }
            return core::segment_intersects_triangle(p(s0), p(s1), p(t0), p(t1), p(t2));
        }
        const std::int32_t v = in0 ? s0 : s1, e = in0 ? s1 : s0;
        // Sharing vertex v, the segment can meet the triangle elsewhere only in its plane.
        if (core::orient3d(p(t0), p(t1), p(t2), p(e)) != 0) return false;
        if (core::segment_intersects_triangle(p(e), p(e), p(t0), p(t1), p(t2))) return true;
        std::int32_t o[2], n = 0;
        for (std::int32_t w : {t0, t1, t2})
            if (w != v) o[n++] = w;
        return core::segment_intersects_triangle(p(v), p(e), p(o[0]), p(o[1]), p(o[1]));
    }

    /// The exact validity test of a candidate tet (a, b, c, q) on base face `base`: positive
    /// volume, no face pointing the wrong way, no front node in the closed tet, no front edge
    /// through a new face, no new edge through a front face (covers the paper's point-in-
    /// tetrahedron, over-the-manifold and edge-face intersection tests (1) and (2) exactly).
    /// The front faces examined are those of `near` (an ADT query over a box holding the tet)
    /// whose boxes meet the tet's box: every front face that can touch the tet, a superset
    /// of the paper's nodes Q_v in the sphere of Eq. 9.
    bool is_valid_tet(const Base& bk, std::int32_t q, const std::vector<std::int32_t>& near) {
        const std::int32_t base = bk.f, a = bk.a[0], b = bk.a[1], c = bk.a[2];
        if (core::orient3d(p(a), p(b), p(c), p(q)) != -1) return false;
        const std::int32_t tv[4] = {a, b, c, q};
        std::int32_t existing[3];
        bool face_new[3], edge_new[3];
        for (int i = 0; i < 3; ++i) {
            // From the star of a_i (base node tv[i]): the front face with the nodes
            // {a_i, a_j, q}, whether a_i q is a front edge.
            const std::int32_t w = tv[(i + 1) % 3];
            existing[i] = -1;
            edge_new[i] = true;
            bool cyclic = false;
            for (int k = bk.star_begin[i]; k < bk.star_begin[i + 1]; ++k) {
                const StarFace& sf = stars_[static_cast<std::size_t>(k)];
                if (sf.u != q && sf.w != q) continue;
                edge_new[i] = false;
                if (existing[i] < 0 && (sf.u == w || sf.w == w)) {
                    existing[i] = sf.f;
                    cyclic = sf.u == w;  // the face is (a_i, w, q) in cyclic order
                }
            }
            // the outward face (a_i, a_j, q) must not already be on the front with that
            // orientation: the tet would lie behind it
            if (cyclic) return false;
            face_new[i] = existing[i] < 0;
        }
        // Reference signs of the opposite vertices for the point-in-tet test: orient3d of a
        // permutation of (a, b, c, q) is orient3d(a, b, c, q) = -1 times its parity (exact
        // signs obey it exactly): identity -1; one swap, and the two odd 4-element
        // permutations below, +1.
        static constexpr int kF[4][4] = {{0, 1, 2, 3}, {0, 1, 3, 2}, {1, 2, 3, 0}, {2, 0, 3, 1}};
        static constexpr int ref[4] = {-1, 1, 1, 1};
        double lo[3], hi[3];
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min({p(a)[k], p(b)[k], p(c)[k], p(q)[k]});
            hi[k] = std::max({p(a)[k], p(b)[k], p(c)[k], p(q)[k]});
        }
        // Outward face planes of the tet, for a conservative filter in doubles: a triangle
        // whose three nodes lie beyond one plane by far more than the rounding error cannot
        // touch the tet; everything else goes to the exact predicates.
        V3 pn[4];
        double pd[4], ptol[4];
        const double diam = (V3(hi[0], hi[1], hi[2]) - V3(lo[0], lo[1], lo[2])).norm() +
                            max_front_edge();
        const double scale = diam + V3(p(a)[0], p(a)[1], p(a)[2]).cwiseAbs().maxCoeff();
        for (int i = 0; i < 4; ++i) {
            const V3 A = x(tv[kF[i][0]]), B = x(tv[kF[i][1]]), C = x(tv[kF[i][2]]);
            pn[i] = (B - A).cross(C - A);
            if (pn[i].dot(x(tv[kF[i][3]]) - A) > 0.0) pn[i] = -pn[i];
            pd[i] = pn[i].dot(A);
            ptol[i] = 1e-9 * pn[i].norm() * scale;
        }
        const std::int32_t stamp = next_mark();
        for (std::int32_t v : tv) mark_[v] = stamp;
        // Per node of `near`, once per call (a node is in several faces): bits 0-5 its outcode
        // against the tet's box (bits 0-2 below lo on x, y, z, bits 3-5 above hi), bits 6-9
        // the planes i it lies beyond by more than ptol, bits 10-13 the planes through it (the
        // tet's own nodes).
        const std::int32_t cstamp = next_code_stamp();
        static constexpr std::uint16_t kOnPlanes[4] = {0b1011, 0b0111, 0b1101, 0b1110};
        for (int j = 0; j < 4; ++j) {
            node_code_[tv[j]] = {cstamp, static_cast<std::uint16_t>(kOnPlanes[j] << 10)};  // in the box
        }
        // The same arithmetic in SSE2, two planes (or axes) per register: for plane i,
        // ((n_x x + n_y y) + n_z z) - d > tol, evaluated in the scalar order, bit for bit.
        const __m128d lo01 = _mm_setr_pd(lo[0], lo[1]), hi01 = _mm_setr_pd(hi[0], hi[1]);
        __m128d nx[2], ny[2], nz[2], nd[2], nt[2];
        for (int h = 0; h < 2; ++h) {
            nx[h] = _mm_setr_pd(pn[2 * h][0], pn[2 * h + 1][0]);
            ny[h] = _mm_setr_pd(pn[2 * h][1], pn[2 * h + 1][1]);
            nz[h] = _mm_setr_pd(pn[2 * h][2], pn[2 * h + 1][2]);
            nd[h] = _mm_setr_pd(pd[2 * h], pd[2 * h + 1]);
            nt[h] = _mm_setr_pd(ptol[2 * h], ptol[2 * h + 1]);
        }
        auto code_of = [&](std::int32_t w) -> std::uint16_t {
            if (node_code_[w].stamp == cstamp) return node_code_[w].code;
            const double* pw = p(w);
            const __m128d xy = _mm_loadu_pd(pw);
            unsigned c = static_cast<unsigned>(_mm_movemask_pd(_mm_cmplt_pd(xy, lo01))) |
                         (pw[2] < lo[2] ? 4u : 0u) |
                         static_cast<unsigned>(_mm_movemask_pd(_mm_cmpgt_pd(xy, hi01))) << 3 |
                         (pw[2] > hi[2] ? 32u : 0u);
            const __m128d px = _mm_set1_pd(pw[0]), py = _mm_set1_pd(pw[1]), pz = _mm_set1_pd(pw[2]);
            for (int h = 0; h < 2; ++h) {
                const __m128d sum = _mm_sub_pd(
                    _mm_add_pd(_mm_add_pd(_mm_mul_pd(nx[h], px), _mm_mul_pd(ny[h], py)),
                               _mm_mul_pd(nz[h], pz)),
                    nd[h]);
                c |= static_cast<unsigned>(_mm_movemask_pd(_mm_cmpgt_pd(sum, nt[h]))) << (6 + 2 * h);
            }
            node_code_[w] = {cstamp, static_cast<std::uint16_t>(c)};
            return static_cast<std::uint16_t>(c);
        };
        // First the filters, over every face of `near`, without a branch on their outcome
        // (a branch here was mispredicted about once a face): the faces left go to `suspects_`.
        suspects_.resize(near.size());
        std::size_t ns = 0;
        for (std::int32_t f : near) {
            const Tri& t = faces_[f].v;
            const std::uint16_t c0 = code_of(t[0]), c1 = code_of(t[1]), c2 = code_of(t[2]);
            // The triangle's box misses the tet's: all three nodes beyond one side of it.
            const bool misses = (c0 & c1 & c2 & 0x3F) != 0;
            // A node of the triangle that spans plane i lies on it exactly; when the others
            // lie beyond it, the triangle meets the closed tet only in nodes (or the edge)
            // they share, which fails none of the tests below: the triangles around the tet's
            // own nodes, most of `near`, need no exact test. Per plane: every node on it or
            // beyond it, and not all on it.
            const unsigned on0 = c0 >> 10, on1 = c1 >> 10, on2 = c2 >> 10;
            const unsigned ok = (on0 | ((c0 >> 6) & 0xF)) & (on1 | ((c1 >> 6) & 0xF)) &
                                (on2 | ((c2 >> 6) & 0xF));
            const bool beyond = (ok & ~(on0 & on1 & on2) & 0xF) != 0;
            // the base and the front faces the tet closes are its own faces
            const bool own = (f == base) | (f == existing[0]) | (f == existing[1]) | (f == existing[2]);
            suspects_[ns] = {f, {c0, c1, c2}};
            ns += !(misses | beyond | own);
        }
        for (std::size_t j = 0; j < ns; ++j) {
            const std::int32_t f = suspects_[j].f;
            const Tri& t = faces_[f].v;
            const std::uint16_t* const code = suspects_[j].code;
            for (int k = 0; k < 3; ++k) {
                const std::int32_t w = t[k];
                if (mark_[w] == stamp) continue;
                mark_[w] = stamp;
                // outside the tet's box, or beyond one of its planes: outside the tet
                if ((code[k] & 0x3FF) != 0) continue;
                bool inside = true;
                for (int i = 0; i < 4 && inside; ++i) {
                    const int s = core::orient3d(p(tv[kF[i][0]]), p(tv[kF[i][1]]),
                                                 p(tv[kF[i][2]]), p(w));
                    inside = s == 0 || s == ref[i];
                }
                if (inside) return false;
            }
            for (int e = 0; e < 3; ++e) {
                const std::int32_t e0 = t[e], e1 = t[(e + 1) % 3];
                // Both ends beyond one side of the tet's box: the edge misses the tet. Both on
                // or beyond one of its planes and not both on it: the edge meets the closed
                // tet at most in an end that is a tet node, no improper intersection with any
                // new face. Otherwise both ends beyond the plane of new face i (plane i + 1:
                // (a, b, q), (b, c, q), (c, a, q)): the edge misses that face.
                const unsigned both = code[e] & code[(e + 1) % 3];
                if ((both & 0x3F) != 0) continue;
                const unsigned s0 = code[e] >> 10, s1 = code[(e + 1) % 3] >> 10;
                if (((s0 | ((code[e] >> 6) & 0xF)) & (s1 | ((code[(e + 1) % 3] >> 6) & 0xF)) &
                     ~(s0 & s1) & 0xF) != 0)
                    continue;
                for (int i = 0; i < 3; ++i)
                    if (face_new[i] && (both & (1u << (7 + i))) == 0 &&
                        improper_intersection(e0, e1, tv[i], tv[(i + 1) % 3], q))
                        return false;
            }
            for (int i = 0; i < 3; ++i)
                if (edge_new[i] && improper_intersection(tv[i], q, t[0], t[1], t[2])) return false;
        }
        return true;
    }

    // ---- paper's quality tests of step 4 (doubles: they only rank and filter) -------------

    bool passes_paper_tests(const Base& bk, std::int32_t q) const {
        const V3 P = x(q);
        // Volume test
        const double vol = core::tet_signed_volume(bk.A[0], bk.A[1], bk.A[2], P);
        if (!(vol > 0.01 * bk.h * bk.area)) return false;
        // Length test
        double limit = 2.0 * bk.h;
        if (bk.eta > 0.6) limit = std::max(limit, bk.max_b);
        if ((bk.xm - P).norm() >= limit) return false;
        const double sin_min = sin_min_;
        const StarFace* const star = stars_.data();
        for (int i = 0; i < 3; ++i) {
            const std::int32_t ai = bk.a[i], aj = bk.a[(i + 1) % 3];
            const V3& Ai = bk.A[i];
            const V3& Aj = bk.A[(i + 1) % 3];
            const int s0 = bk.star_begin[i], s1 = bk.star_begin[i + 1];
            // is A_ki q a front edge, (A_ki, A_kj, q) a front face?
            bool edge_new = true, face_new = true;
            for (int k = s0; k < s1; ++k) {
                const StarFace& sf = star[k];
                if (sf.u != q && sf.w != q) continue;
                edge_new = false;
                if (sf.u == aj || sf.w == aj) {
                    face_new = false;
                    break;
                }
            }
            if (edge_new) {
                const V3 d = (P - Ai).normalized();
                // Over the manifold test: P above the plane of some front face at A_ki (the
                // exact tests of is_valid_tet decide validity; this one only filters)
                bool over = false;
                for (int k = s0; k < s1 && !over; ++k) over = d.dot(star[k].n) > 0.0;
                if (!over) return false;
                // Edge-face angle test: edge A_ki P against the front faces at A_ki
                for (int k = s0; k < s1; ++k) {
                    const StarFace& sf = star[k];
                    const double sn = d.dot(sf.n);
                    if (std::abs(sn) >= sin_min) continue;
                    const V3 dp = d - sn * sf.n;
                    const V3 u = sf.U - Ai, w = sf.W - Ai;
                    if (u.cross(dp).dot(sf.n) >= 0.0 && dp.cross(w).dot(sf.n) >= 0.0) return false;
                }
            }
            if (face_new) {
                const V3& e = bk.e[i];
                V3 up = P - Ai;
                up -= up.dot(e) * e;
                const double upl = up.norm();
                if (upl == 0.0) return false;
                up /= upl;
                // Face-face (dihedral) angle test against every front face on edge A_ki A_kj
                for (int k = bk.wing_begin[i]; k < bk.wing_begin[i + 1]; ++k) {
                    const Wing& wg = wings_[static_cast<std::size_t>(k)];
                    if (wg.v == q) continue;
                    // cos(angle) = up . vp / |vp| >= cos_min, squared (cos_min > 0): no root
                    const double c = up.dot(wg.vp);
                    if (wg.vpl2 == 0.0 || (c > 0.0 && c * c >= cos2_min_ * wg.vpl2)) return false;
                }
                // Edge-face angle test: the new face against the front edges at A_ki, A_kj
                const V3 nf = (Aj - Ai).cross(P - Ai).normalized();
                for (int end = 0; end < 2; ++end) {
                    const V3& O = end == 0 ? Ai : Aj;
                    const V3 r1 = (end == 0 ? Aj : Ai) - O, r2 = P - O;
                    const V3 c12 = r1.cross(r2);
                    // Every front edge at O but O-A_kj and O-q (those of the new face)
                    const std::int32_t other = end == 0 ? aj : ai;
                    const int m = (i + end) % 3;
                    const EdgeAt* const eb = edges_.data() + bk.edge_begin[m];
                    const EdgeAt* const ee = edges_.data() + bk.edge_begin[m + 1];
                    for (const EdgeAt* ed = eb; ed != ee; ++ed) {
                        if (ed->v == other || ed->v == q) continue;
                        // d unnormalised: |sin| = |d . nf| / |d| < sin_min, squared; the
                        // wedge test below only needs the direction of d
                        if (ed->dl2 == 0.0) return false;
                        const double sn = ed->d.dot(nf);
                        if (sn * sn >= sin2_min_ * ed->dl2) continue;
                        const V3 dp = ed->d - sn * nf;
                        // inside the face's wedge at O (between r1 and r2)?
                        if (r1.cross(dp).dot(c12) >= 0.0 && dp.cross(r2).dot(c12) >= 0.0)
                            return false;
                    }
                }
            }
        }
        return true;
    }

    // ---- §3.1.3 n-th level front setup ----------------------------------------------------
    void setup_level();
    bool is_visible(std::int32_t j, std::int32_t i);

    // ---- §3.1.4 / §3.1.5 -------------------------------------------------------------------
    bool is_active(std::int32_t v) const { return setup_stamp_[v] == front_no_; }
    bool is_eligible(std::int32_t f, int stage) const {
        const Tri& t = faces_[f].v;
        const int n = is_active(t[0]) + is_active(t[1]) + is_active(t[2]);
        return stage == 1 ? n == 3 : n >= 1;
    }
    Base make_base(std::int32_t f, bool active_only);
    bool try_base(std::int32_t f, bool active_only, bool relaxed);
    void run_stage(int stage, bool allow_remesh, std::int64_t& attempts);
    bool remesh_around(std::int32_t f);
    void init_front(const core::SurfaceNetwork& surface);
    void closing_round(std::int32_t rings);
    RegionResult result() const;
    [[noreturn]] void fail(const std::string& why) const;
};

void RegionMesher::init_front(const core::SurfaceNetwork& s) {
    // §3.1.2: the region's closed boundary, faces pointing INTO the region (Fig. 2): faces with
    // region_in == R reversed, faces with region_out == R as they are.
    std::vector<std::int32_t> local(s.vertex_count(), -1);
    std::vector<std::int32_t> faces;
    for (std::size_t f = 0; f < s.face_count(); ++f) {
        const bool in = s.region_in[f] == region_, out = s.region_out[f] == region_;
        if (in == out) continue;  // not ours, or an inner face of the region (cancels)
        faces.push_back(static_cast<std::int32_t>(f));
        for (std::int32_t v : s.faces[f]) local[static_cast<std::size_t>(v)] = 0;
    }
    for (std::size_t v = 0; v < local.size(); ++v) {
        if (local[v] < 0) continue;
        local[v] = push_node(s.point(static_cast<std::int32_t>(v)), 0);
        global_of_local_.push_back(static_cast<std::int32_t>(v));
    }
    boundary_nodes_ = node_count();
    for (std::int32_t f : faces) {
        const auto& t = s.faces[static_cast<std::size_t>(f)];
        std::int32_t a = local[t[0]], b = local[t[1]], c = local[t[2]];
        if (s.region_in[f] == region_) std::swap(b, c);
        if (a == b || b == c || a == c)
            FM_THROW(InputError, "region " + std::to_string(region_) + ": face " +
                                     std::to_string(f) + " has a repeated vertex");
        const std::int32_t g = find_face(a, b, c);
        if (g >= 0) {
            if (same_cycle(faces_[g].v, a, b, c))
                FM_THROW(InputError, "region " + std::to_string(region_) + ": face " +
                                         std::to_string(f) + " appears twice near " + where(a));
            remove_face(g);  // both sides of a zero-thickness sheet: nothing to mesh
            continue;
        }
        add_face(a, b, c);
    }
    remesh_budget_ = 1000 + 2 * static_cast<std::int64_t>(faces.size());
}

bool RegionMesher::is_visible(std::int32_t j, std::int32_t i) {
    // Eq. 5 visibility: i lies in front of j and no front face separates them: none of the
    // front faces whose box meets the box of the segment (from the face ADT) crosses it.
    if ((x(i) - x(j)).dot(node_normal(j)) <= 0.0) return false;
    core::AdtBox box = core::AdtBox::of_point(x(j));
    box.extend(x(i));
    gather_faces(box, visible_faces_);
    for (std::int32_t f : visible_faces_) {
        const Tri& t = faces_[f].v;
        if (t[0] == i || t[1] == i || t[2] == i || t[0] == j || t[1] == j || t[2] == j) continue;
        if (core::segment_intersects_triangle(p(j), p(i), p(t[0]), p(t[1]), p(t[2]))) return false;
    }
    return true;
}

void RegionMesher::setup_level() {
    adt_.compact();
    face_adt_.compact();
    const std::int32_t n = node_count();
    std::vector<double> nsum(3 * static_cast<std::size_t>(n), 0.0), asum(n, 0.0), rs(n, 0.0),
        ho(n, 0.0), c(n, 0.0);
    std::vector<std::int32_t> cnt(n, 0), front_nodes;
    for (std::int32_t f = 0; f < static_cast<std::int32_t>(faces_.size()); ++f) {
        if (!falive_[f]) continue;
        const Tri& t = faces_[f].v;
        for (int k = 0; k < 3; ++k) {
            const std::int32_t v = t[k];
            for (int a = 0; a < 3; ++a) nsum[3 * v + a] += faces_[f].n[a];
            asum[v] += faces_[f].area;
            ++cnt[v];
            rs[v] = std::max(rs[v], (x(t[(k + 1) % 3]) - x(v)).norm());
            rs[v] = std::max(rs[v], (x(t[(k + 2) % 3]) - x(v)).norm());
        }
    }
    for (std::int32_t v = 0; v < n; ++v) {
        if (cnt[v] == 0) continue;
        front_nodes.push_back(v);
        setup_stamp_[v] = front_no_;
        V3 s(nsum[3 * v], nsum[3 * v + 1], nsum[3 * v + 2]);
        const double l = s.norm();
        s = l > 1e-12 ? V3(s / l) : face_normal(face_head_[v] / 3);  // Eq. 3
        for (int a = 0; a < 3; ++a) normal_[3 * v + a] = s[a];
        ho[v] = 1.24 * params_.stretching * std::sqrt(asum[v] / cnt[v]);  // Eq. 4
    }
    // Eq. 5: influence regions (x_j, 3 r_sj), found through the ADT of front nodes. c_i is the
    // correction of largest |c| over the visible pairs, ties to the larger value: the same for
    // any order of the pairs, so the tree's walk order decides nothing. Nodes of consecutive
    // ids lie close together, mostly: a group of them shares one box query over their spheres,
    // and each takes the nodes of its own sphere from it by the sphere query's own test. A
    // group grows (up to 8 nodes) while its box stays within 3 times the first sphere's radius
    // on every axis (hippocampus: 12% less setup than a query per node).
    auto stronger = [](double a, double b) {  // a replaces b
        return std::abs(a) > std::abs(b) || (std::abs(a) == std::abs(b) && a > b);
    };
    constexpr std::size_t kGroup = 8;
    std::vector<std::int32_t> ids;
    for (std::size_t g0 = 0; g0 < front_nodes.size();) {
        const double R0 = 3.0 * rs[front_nodes[g0]];
        core::AdtBox group;
        std::size_t g1 = g0;
        for (; g1 < front_nodes.size() && g1 - g0 < kGroup; ++g1) {
            const std::int32_t j = front_nodes[g1];
            core::AdtBox grown = group;
            grown.extend(x(j) - V3::Constant(3.0 * rs[j]));
            grown.extend(x(j) + V3::Constant(3.0 * rs[j]));
            if (g1 > g0 && (grown.hi - grown.lo).maxCoeff() > 3.0 * R0) break;
            group = grown;
        }
        adt_.query_box(group, ids, core::AdtOrder::walk);
        for (; g0 < g1; ++g0) {
            const std::int32_t j = front_nodes[g0];
            const double R = 3.0 * rs[j];
            const double R2 = R * R;
            const V3 Nj = node_normal(j);
            const V3 Xj = x(j);
            for (std::int32_t i : ids) {
                if (!(rs[j] < rs[i])) continue;
                // Adt::query_sphere's own test
                if (!(core::squared_distance(core::AdtBox::of_point(x(i)), Xj) <= R2)) continue;
                if (node_normal(i).dot(Nj) >= 0.5) continue;  // angle must exceed 60 degrees
                const double d = (x(i) - x(j)).norm();
                if (d > R || d == 0.0) continue;
                const double coji = 0.05 * (3.0 * rs[i] / d) * (ho[j] - ho[i]) / ho[j];
                const double cji = std::min(std::max(coji, -0.6), 0.5);
                const double coij = 0.05 * (3.0 * rs[j] / d) * (ho[i] - ho[j]) / ho[i];
                const double cij = std::min(std::max(coij, -0.6), 0.5);
                // the (costly) visibility test only when it can change c_i or c_j
                const bool ci = stronger(cji, c[i]), cj = stronger(cij, c[j]);
                if (!ci && !cj) continue;
                if (!is_visible(j, i)) continue;
                if (ci) c[i] = cji;
                if (cj) c[j] = cij;
            }
        }
    }
    for (std::int32_t v : front_nodes) {
        h_[v] = (1.0 + c[v]) * ho[v];                   // Eq. 6
        rs_[v] = std::max(1.0 + c[v], 1.0) * rs[v];     // Eq. 7
    }
    // Laplacian smoothing of h'_o over the front edges (each edge seen from its two faces).
    std::vector<double> sum(n, 0.0);
    std::vector<std::int32_t> num(n, 0);
    for (int it = 0; it < params_.height_smoothing_iterations; ++it) {
        for (std::int32_t v : front_nodes) {
            sum[v] = 0.0;
            num[v] = 0;
        }
        for (std::int32_t f = 0; f < static_cast<std::int32_t>(faces_.size()); ++f) {
            if (!falive_[f]) continue;
            const Tri& t = faces_[f].v;
            for (int k = 0; k < 3; ++k) {
                sum[t[k]] += h_[t[(k + 1) % 3]] + h_[t[(k + 2) % 3]];
                num[t[k]] += 2;
            }
        }
        for (std::int32_t v : front_nodes) h_[v] = 0.5 * h_[v] + 0.5 * sum[v] / num[v];
    }
}

RegionMesher::Base RegionMesher::make_base(std::int32_t f, bool active_only) {
    Base bk;
    bk.f = f;
    const Tri& t = faces_[f].v;
    stars_.clear();
    for (int i = 0; i < 3; ++i) {
        bk.a[i] = t[i];
        bk.A[i] = x(t[i]);
        bk.star_begin[i] = static_cast<std::int32_t>(stars_.size());
        for (std::int32_t k = face_head_[t[i]]; k >= 0; k = faces_[k / 3].next[k % 3]) {
            const std::int32_t g = k / 3, c = k % 3;
            const std::int32_t u = faces_[g].v[(c + 1) % 3], w = faces_[g].v[(c + 2) % 3];
            stars_.push_back({g, u, w, x(u), x(w), face_normal(g)});
        }
    }
    bk.star_begin[3] = static_cast<std::int32_t>(stars_.size());
    // What the angle tests of step 4 read for every candidate but do not depend on it: the
    // base edges' directions, the wings of each edge, and the front edges at each a_i.
    wings_.clear();
    edges_.clear();
    for (int i = 0; i < 3; ++i) {
        const std::int32_t aj = t[(i + 1) % 3];
        const V3& Ai = bk.A[i];
        bk.e[i] = (bk.A[(i + 1) % 3] - Ai).normalized();
        bk.wing_begin[i] = static_cast<std::int32_t>(wings_.size());
        bk.edge_begin[i] = static_cast<std::int32_t>(edges_.size());
        const int s0 = bk.star_begin[i], s1 = bk.star_begin[i + 1];
        const std::int32_t stamp = next_mark();
        for (int k = s0; k < s1; ++k) mark_[stars_[static_cast<std::size_t>(k)].u] = stamp;
        for (int k = s0; k < s1; ++k) {
            const StarFace& sf = stars_[static_cast<std::size_t>(k)];
            // every front edge at a_i is (a_i, u) of a face, or (a_i, w) of one where w is the
            // u of none (never in a closed fan)
            const V3 du = sf.U - Ai;
            edges_.push_back({du, du.squaredNorm(), sf.u});
            if (mark_[sf.w] != stamp) {
                const V3 dw = sf.W - Ai;
                edges_.push_back({dw, dw.squaredNorm(), sf.w});
            }
            if (sf.f == f || (sf.u != aj && sf.w != aj)) continue;
            V3 vp = (sf.u != aj ? sf.U : sf.W) - Ai;
            vp -= vp.dot(bk.e[i]) * bk.e[i];
            wings_.push_back({sf.u != aj ? sf.u : sf.w, vp, vp.squaredNorm()});
        }
    }
    bk.wing_begin[3] = static_cast<std::int32_t>(wings_.size());
    bk.edge_begin[3] = static_cast<std::int32_t>(edges_.size());
    bk.n = face_normal(f);
    bk.area = faces_[f].area;
    // Eq. 8 from the nodes on the n-th level front (§3.1.5); other nodes fall back on the
    // height they last had, or on Eq. 4 of this face alone.
    double hs = 0.0;
    int hn = 0;
    for (int i = 0; i < 3; ++i) {
        if (active_only && !is_active(t[i])) continue;
        if (h_[t[i]] > 0.0) {
            hs += h_[t[i]];
            ++hn;
        }
    }
    const double hmean = hn > 0 ? hs / hn : 1.24 * params_.stretching * std::sqrt(bk.area);
    bk.h = std::max(hmean, 0.5 * std::sqrt(bk.area));  // Eq. 8
    bk.eta = core::triangle_skewness(bk.A[0], bk.A[1], bk.A[2]);
    bk.xm = (bk.A[0] + bk.A[1] + bk.A[2]) / 3.0;
    bk.xo = bk.xm;
    if (bk.eta > 0.5) {  // Fig. 6b: the centre of the longest edge
        int best = 0;
        double lmax = -1.0;
        for (int i = 0; i < 3; ++i) {
            const double l = (bk.A[(i + 1) % 3] - bk.A[i]).squaredNorm();
            if (l > lmax) {
                lmax = l;
                best = i;
            }
        }
        bk.xo = 0.5 * (bk.A[best] + bk.A[(best + 1) % 3]);
    }
    const V3 xp = bk.xo + bk.h * bk.n;  // Eq. 10, g = 1
    bk.xc = 0.4 * bk.xm + 0.6 * xp;     // Eq. 11
    // B_ki: third node of a neighbour across each edge (length test)
    for (int i = 0; i < 3; ++i) {
        const std::int32_t w = t[(i + 1) % 3];
        for (int k = bk.star_begin[i]; k < bk.star_begin[i + 1]; ++k) {
            const StarFace& sf = stars_[static_cast<std::size_t>(k)];
            if (sf.f == f || (sf.u != w && sf.w != w)) continue;
            bk.max_b = std::max(bk.max_b, ((sf.u != w ? sf.U : sf.W) - bk.xc).norm());
            break;
        }
    }
    return bk;
}

/// §3.1.4 steps 1-4 for base f: candidates from the ADT in the sphere of Eq. 11 (w = 1..10)
/// ordered by Eq. 12, the new point of Eq. 10 (g = 0.7^i, i = 0..3) after those of w = 1.
/// Failing candidates fail again for a larger w, so each is tested once: first those of
/// w = 1, then the new points, then those of w = 2..10 in order of (w, Eq. 12).
/// `relaxed` (closing phase) drops the paper's quality filters but keeps every exact test.
/// Candidates come from a sphere query on the ADT of front nodes; each candidate that passes
/// the cheap tests fetches the front faces meeting its tet's box from the ADT of front face
/// boxes for the exact validity test (the paper's Q_v of Eq. 9 and their faces, a superset).
bool RegionMesher::try_base(std::int32_t f, bool active_only, bool relaxed) {
    const Base bk = make_base(f, active_only);
    static constexpr double kGs[4] = {1.0, 0.7, 0.49, 0.343};  // g = 0.7^i, Eq. 10
    const double r1 = 1.1 * bk.h, r10 = std::pow(1.1, 10) * bk.h;  // Eq. 11, w = 1 and 10
    const double rrel = std::max(3.0 * bk.h, 2.0 * std::sqrt(bk.area) + bk.max_b);
    core::AdtBox base_box;
    for (int i = 0; i < 3; ++i) base_box.extend(bk.A[i]);

    std::vector<Cand>& cands = cands_;
    std::vector<std::int32_t>& near = near_faces_;
    const bool small_front = relaxed && front_size_ <= 64;
    V3 centroid = V3::Zero();
    int ncent = 0;
    bool near_ready = false;  // `near` holds every front face (small closing front)
    // `near` holds every front face whose box meets `fetched`: those a validity test of a
    // tet (base, q) with q inside `fetched` needs.
    core::AdtBox fetched;
    // Candidates in the shell rmin < |x - x_ck| <= r (all front nodes above the base for a
    // small closing front). With `from_faces` (rmin < 0), the front nodes come from one query
    // of the ADT of front face boxes over the box of the base and the sphere: every front node
    // in the sphere is a node of a face found there, and the faces found also serve the
    // validity tests of every candidate inside that box, most new points of Eq. 10 too (one
    // outside fetches its own). Otherwise they come from the ADT of front nodes.
    auto collect = [&](double rmin, double r, bool from_faces) {
        cands.clear();
        if (small_front) {
            near.clear();
            for (std::int32_t g = 0; g < static_cast<std::int32_t>(faces_.size()); ++g)
                if (falive_[g]) near.push_back(g);
            near_ready = true;
        } else if (from_faces) {
            fetched = base_box;
            fetched.extend(bk.xc - V3::Constant(r * (1.0 + 1e-9)));
            fetched.extend(bk.xc + V3::Constant(r * (1.0 + 1e-9)));
            gather_faces(fetched, near);
        } else {
            // a hair wider than r: the test below decides
            adt_.query_sphere(bk.xc, r * (1.0 + 1e-9), node_ids_);
        }
        if (small_front || from_faces) {
            // each node once, in order of first appearance; written always, kept when new (a
            // branch on the mark was mispredicted about once a node)
            const std::int32_t stamp = next_mark();
            node_ids_.resize(3 * near.size());
            std::size_t n = 0;
            for (std::int32_t g : near)
                for (std::int32_t q : faces_[g].v) {
                    node_ids_[n] = q;
                    n += mark_[q] != stamp;
                    mark_[q] = stamp;
                }
            node_ids_.resize(n);
        }
        for (std::int32_t q : node_ids_) {
            if (q == bk.a[0] || q == bk.a[1] || q == bk.a[2]) continue;
            const double d = (x(q) - bk.xc).norm();
            if (!small_front && (d > r || d <= rmin)) continue;
            if (core::orient3d(p(bk.a[0]), p(bk.a[1]), p(bk.a[2]), p(q)) != -1) continue;
            if (relaxed) {
                centroid += x(q);
                ++ncent;
            }
            cands.push_back({0.0, d, q});
        }
        if (cands.size() < 2) return;  // nothing to order
        for (Cand& c : cands) {
            const double d = c.key1;
            const double eps = core::tet_skewness(bk.A[0], bk.A[1], bk.A[2], x(c.id));
            if (relaxed) {
                c.key0 = eps;  // then d
            } else {
                // w: the first sphere of Eq. 11 holding q; Eq. 12 orders within it
                c.key0 = d <= r1 ? 1.0 : std::max(
                    1.0, std::ceil(std::log(std::max(d / bk.h, 1e-300)) / std::log(1.1) - 1e-12));
                c.key1 = (eps + 0.1) * d;
            }
        }
        std::sort(cands.begin(), cands.end(), [](const Cand& l, const Cand& r2) {
            if (l.key0 != r2.key0) return l.key0 < r2.key0;
            if (l.key1 != r2.key1) return l.key1 < r2.key1;
            return l.id < r2.id;
        });
    };
    // The front faces a validity test of the tet (base, q) needs: those whose box meets the
    // box of the tet, from the ADT of front face boxes. A fetch also serves every later
    // candidate inside its box (the front does not change before try_base returns).
    auto ensure_near = [&](std::int32_t q) {
        if (near_ready) return;
        const V3 Q = x(q);
        if ((Q.array() >= fetched.lo.array()).all() && (Q.array() <= fetched.hi.array()).all())
            return;
        fetched = base_box;
        fetched.extend(Q);
        gather_faces(fetched, near);
    };
    const double min_vol = 1e-6 * bk.area * std::sqrt(bk.area);
    auto try_existing = [&](std::int32_t q) {
        if (relaxed) {
            if (!(core::tet_signed_volume(bk.A[0], bk.A[1], bk.A[2], x(q)) > min_vol)) return false;
        } else if (!passes_paper_tests(bk, q)) {
            ++stat_[2];
            return false;
        }
        ensure_near(q);
        if (!is_valid_tet(bk, q, near)) {
            ++stat_[3];
            return false;
        }
        add_tet(bk.a[0], bk.a[1], bk.a[2], q);
        ++stat_[4];
        return true;
    };
    auto try_new = [&](const V3& P) {
        const std::int32_t q = push_node(P, front_no_ + 1);
        bool ok = relaxed ? core::tet_signed_volume(bk.A[0], bk.A[1], bk.A[2], P) > min_vol
                          : passes_paper_tests(bk, q);
        if (!ok) ++stat_[2];
        if (ok) ensure_near(q);
        const bool valid = ok && is_valid_tet(bk, q, near);
        if (ok && !valid) ++stat_[3];
        if (!valid) {
            pop_node();
            return false;
        }
        add_tet(bk.a[0], bk.a[1], bk.a[2], q);
        ++stat_[5];
        return true;
    };
    if (relaxed) {
        collect(-1.0, rrel, false);
        for (const Cand& c : cands)
            if (try_existing(c.id)) return true;
        for (double g : {1.0, 0.7, 0.49, 0.343, 0.25, 0.1})
            if (try_new(bk.xo + g * bk.h * bk.n)) return true;
        if (ncent > 0) {
            // centre of the base and the nodes that see it: a star point for small cavities
            const V3 c = (centroid + bk.A[0] + bk.A[1] + bk.A[2]) / (ncent + 3);
            if (try_new(c)) return true;
        }
        return false;
    }
    collect(-1.0, r1, true);  // w = 1
    for (const Cand& c : cands)
        if (try_existing(c.id)) return true;
    for (double g : kGs)
        if (try_new(bk.xo + g * bk.h * bk.n)) return true;
    collect(r1, r10, false);  // w = 2 .. 10
    for (const Cand& c : cands)
        if (try_existing(c.id)) return true;
    return false;
}

/// §3.2 local remeshing around base f: removes the tets of the n-th level touching its nodes
/// (all local tets when there are none), a ring more for every earlier remeshing there.
bool RegionMesher::remesh_around(std::int32_t f) {
    if (remeshes_ >= remesh_budget_) return false;
    const Tri t = faces_[f].v;
    std::int32_t r = 0;
    for (std::int32_t v : t) r = std::max(r, remesh_count_[v]);
    if (r >= params_.max_remesh_per_node) return false;
    for (std::int32_t v : t) ++remesh_count_[v];
    std::vector<std::int32_t> nodes(t.begin(), t.end()), tets;
    for (int ring = 0; ring <= r; ++ring) {
        for (int pass = 0; pass < 2; ++pass) {
            tets.clear();
            for (std::int32_t v : nodes)
                for (std::int32_t k = tet_head_[v]; k >= 0; k = tnext_[k]) {
                    const std::int32_t tt = k / 4;
                    if (talive_[tt] && (pass == 1 || tfront_[tt] == front_no_)) tets.push_back(tt);
                }
            if (!tets.empty()) break;
        }
        std::sort(tets.begin(), tets.end());
        tets.erase(std::unique(tets.begin(), tets.end()), tets.end());
        if (ring < r) {
            for (std::int32_t tt : tets) nodes.insert(nodes.end(), tv_[tt].begin(), tv_[tt].end());
            std::sort(nodes.begin(), nodes.end());
            nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
        }
    }
    if (tets.empty()) return false;
    ++remeshes_;
    std::vector<std::int32_t> restored;
    for (std::int32_t tt : tets) {
        new_faces_.clear();
        remove_tet(tt);
        restored.insert(restored.end(), new_faces_.begin(), new_faces_.end());
    }
    new_faces_ = restored;
    return true;
}

void RegionMesher::run_stage(int stage, bool allow_remesh, std::int64_t& attempts) {
    // §3.1.4: smallest-area base first. In the layered front (allow_remesh), to a factor of
    // 2^(1/4) in area: within an area class the bases go in Morton order of their centroids,
    // so consecutive bases are neighbours and the ADT walks and the node and face arrays they
    // touch stay in the caches. Against the exact order on Colin27 (alpha 1.15): about 27% less
    // CPU, the same skewness figures (mean 0.4272 vs 0.4271, > 0.8: 10.03% vs 10.02%), 4% fewer
    // local remeshings. The closing phase, which fills small leftover cavities, keeps the exact
    // order: it closes cavities the coarse order leaves it (an AAL region it failed on).
    BaseQueue queue(allow_remesh);
    const core::AdtBox domain = adt_.domain();
    const bool spatial = allow_remesh;
    auto push = [&](std::int32_t f) {
        if (!falive_[f] || !is_eligible(f, stage)) return;
        const double a = faces_[f].area;
        if (!spatial) {
            queue.push({a, 0, f, faces_[f].stamp});
            return;
        }
        const double area_class = a > 0.0 ? std::floor(4.0 * std::log2(a)) : -1e300;
        const Tri& t = faces_[f].v;
        queue.push({area_class, morton_code((x(t[0]) + x(t[1]) + x(t[2])) / 3.0, domain), f,
                    faces_[f].stamp});
    };
    queue.begin_bulk();
    for (std::int32_t f = 0; f < static_cast<std::int32_t>(faces_.size()); ++f) push(f);
    queue.end_bulk();
    const std::int64_t max_attempts = 50 * static_cast<std::int64_t>(faces_.size()) + 100000;
    std::int64_t local_attempts = 0;
    while (!queue.empty()) {
        const BaseQueue::Item it = queue.pop();
        const std::int32_t f = it.f;
        if (!falive_[f] || faces_[f].stamp != it.stamp || faces_[f].failed == faces_[f].stamp) continue;
        if (!is_eligible(f, stage)) continue;
        if (++local_attempts > max_attempts) break;
        ++attempts;
        ++stat_[0];
        if (try_base(f, stage == 2, false)) {
            ++stat_[5 + stage];
            for (std::int32_t g : new_faces_) push(g);
            continue;
        }
        ++stat_[1];
        // w reached 10: §3.2 local remeshing, else leave the base for later
        if (allow_remesh && remesh_around(f)) {
            std::vector<std::int32_t> restored = new_faces_;
            for (std::int32_t g : restored) push(g);
            if (falive_[f]) push(f);
            continue;
        }
        if (falive_[f]) faces_[f].failed = faces_[f].stamp;
    }
}

void RegionMesher::closing_round(std::int32_t rings) {
    // Enlarge every cavity: remove `rings` rings of tets around the nodes left on the front.
    if (rings > 0) {
        std::vector<std::int32_t> nodes;
        for (std::int32_t f = 0; f < static_cast<std::int32_t>(faces_.size()); ++f)
            if (falive_[f]) nodes.insert(nodes.end(), faces_[f].v.begin(), faces_[f].v.end());
        std::vector<std::int32_t> tets;
        for (std::int32_t ring = 0; ring < rings; ++ring) {
            std::sort(nodes.begin(), nodes.end());
            nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
            tets.clear();
            for (std::int32_t v : nodes)
                for (std::int32_t k = tet_head_[v]; k >= 0; k = tnext_[k])
                    if (talive_[k / 4]) tets.push_back(k / 4);
            std::sort(tets.begin(), tets.end());
            tets.erase(std::unique(tets.begin(), tets.end()), tets.end());
            for (std::int32_t t : tets) nodes.insert(nodes.end(), tv_[t].begin(), tv_[t].end());
        }
        for (std::int32_t t : tets) {
            new_faces_.clear();
            remove_tet(t);
        }
        // refill with the layered front first (good elements), then relaxed
        ++front_no_;
        setup_level();
        std::int64_t attempts = 0;
        run_stage(1, false, attempts);
        run_stage(2, false, attempts);
    }
    // Relaxed filling: any valid tet, smallest faces first; bounded passes.
    for (int pass = 0; pass < 4 && front_size_ > 0; ++pass) {
        bool progress = false;
        std::vector<std::pair<double, std::int32_t>> order;
        for (std::int32_t f = 0; f < static_cast<std::int32_t>(faces_.size()); ++f)
            if (falive_[f]) order.push_back({faces_[f].area, f});
        std::sort(order.begin(), order.end());
        std::vector<std::int32_t> stamps(faces_.size());
        for (auto [a, f] : order) stamps[f] = faces_[f].stamp;
        for (auto [a, f] : order) {
            (void)a;
            if (f >= static_cast<std::int32_t>(stamps.size()) || !falive_[f] ||
                faces_[f].stamp != stamps[f])
                continue;
            if (try_base(f, false, true)) progress = true;
        }
        if (!progress) break;
    }
}

void RegionMesher::fail(const std::string& why) const {
    std::int32_t f = 0;
    while (f < static_cast<std::int32_t>(faces_.size()) && !falive_[f]) ++f;
    std::string place = f < static_cast<std::int32_t>(faces_.size()) ? where(faces_[f].v[0]) : "?";
    FM_THROW(MeshingError, "tetra: region " + std::to_string(region_) + ": " + why + " near " +
                               place + ", " + std::to_string(front_size_) +
                               " front triangles left");
}

RegionResult RegionMesher::run() {
    RegionResult res;
    std::int64_t attempts = 0;
    const std::int32_t max_levels = 100000;
    std::int32_t levels = 0;
    // §3.1.3-3.1.5: level after level until the front is empty or stalls.
    for (front_no_ = 0; front_size_ > 0 && front_no_ < max_levels; ++front_no_) {
        setup_level();
        const std::int64_t tets_before = static_cast<std::int64_t>(tv_.size());
        const std::int64_t remesh_before = remeshes_;
        run_stage(1, true, attempts);
        run_stage(2, true, attempts);
        ++levels;
        if (log_)
            log_("tetra: region " + std::to_string(region_) + ", level " +
                 std::to_string(front_no_) + ": " + std::to_string(alive_tets_) + " tets, " +
                 std::to_string(front_size_) + " front triangles, " + std::to_string(remeshes_) +
                 " remeshings");
        if (static_cast<std::int64_t>(tv_.size()) == tets_before && remeshes_ == remesh_before)
            break;  // stalled: nothing changed in a whole level
    }
    ++front_no_;
    // Closing phase for the cavities the layered front could not fill.
    std::int64_t closing_rounds = 0;
    const std::int64_t tets_before_closing = alive_tets_;
    for (std::int32_t round = 0; front_size_ > 0 && round <= params_.max_closing_rounds; ++round) {
        ++closing_rounds;
        closing_round(round);
    }
    if (front_size_ > 0) fail("the front cannot be closed");
    res.region = region_;
    res.boundary_nodes = boundary_nodes_;
    res.global_of_local = global_of_local_;
    res.xyz.assign(xyz_.begin(), xyz_.end());
    res.level.assign(level_.begin(), level_.end());
    res.tets.reserve(static_cast<std::size_t>(alive_tets_));
    for (std::size_t t = 0; t < tv_.size(); ++t)
        if (talive_[t]) res.tets.push_back(tv_[t]);
    res.remeshes = remeshes_;
    res.closing_rounds = closing_rounds;
    res.closing_tets = alive_tets_ - tets_before_closing;
    res.levels = levels;
    for (int i = 0; i < 8; ++i) res.stat[i] = stat_[i];
    return res;
}

}  // namespace

core::TetMesh tetra(const core::SurfaceNetwork& surface, const TetraParams& params,
                    core::StageContext& ctx) {
    validate(params);
    if (surface.face_count() == 0) FM_THROW(InputError, "tetra: the surface has no triangles");
    const std::size_t nv = surface.vertex_count();
    for (std::size_t f = 0; f < surface.face_count(); ++f)
        for (std::int32_t v : surface.faces[f])
            if (v < 0 || static_cast<std::size_t>(v) >= nv)
                FM_THROW(InputError, "tetra: face " + std::to_string(f) + " has a vertex id out of range");
    const std::vector<Label> labels = core::region_labels(surface);
    std::vector<RegionResult> results(labels.size());
    std::vector<std::exception_ptr> errors(labels.size());
    std::mutex ctx_mutex;
    std::size_t done = 0;
    tbb::parallel_for(std::size_t(0), labels.size(), [&](std::size_t r) {
        try {
            RegionMesher mesher(surface, labels[r], params, [&](const std::string& m) {
                std::lock_guard<std::mutex> lock(ctx_mutex);
                ctx.debug(m);
            });
            results[r] = mesher.run();
        } catch (...) {
            errors[r] = std::current_exception();
        }
        std::lock_guard<std::mutex> lock(ctx_mutex);
        ++done;
        ctx.progress(static_cast<double>(done) / static_cast<double>(labels.size()),
                     "tetra: regions meshed");
    });
    for (const auto& e : errors)
        if (e) std::rethrow_exception(e);

    // Deterministic merge: surface nodes first, then each region's new nodes in label order.
    core::TetMesh mesh;
    mesh.xyz = surface.xyz;
    mesh.level.assign(nv, 0);
    mesh.faces = surface.faces;
    mesh.region_in = surface.region_in;
    mesh.region_out = surface.region_out;
    mesh.surface_vertices = static_cast<std::int32_t>(nv);
    std::int64_t remeshes = 0, closing_rounds = 0, closing_tets = 0, levels = 0;
    std::int64_t stat[8] = {};
    for (const RegionResult& res : results) {
        const std::int32_t nl = static_cast<std::int32_t>(res.level.size());
        std::vector<std::int32_t> global(nl, -1);
        for (std::int32_t v = 0; v < res.boundary_nodes; ++v) global[v] = res.global_of_local[v];
        for (const Tet& t : res.tets) {
            Tet g;
            for (int k = 0; k < 4; ++k) {
                const std::int32_t v = t[k];
                if (global[v] < 0) {
                    global[v] = mesh.add_node(
                        Eigen::Vector3d(res.xyz[3 * v], res.xyz[3 * v + 1], res.xyz[3 * v + 2]));
                    mesh.level.push_back(res.level[v]);
                }
                g[k] = global[v];
            }
            mesh.add_tet(g[0], g[1], g[2], g[3], res.region);
        }
        remeshes += res.remeshes;
        closing_rounds += res.closing_rounds;
        closing_tets += res.closing_tets;
        levels = std::max<std::int64_t>(levels, res.levels);
        for (int i = 0; i < 8; ++i) stat[i] += res.stat[i];
    }
    for (int i = 0; i < 8; ++i) ctx.count(std::string("tetra.") + kStatNames[i], static_cast<double>(stat[i]));
    ctx.count("tetra.tets", static_cast<double>(mesh.tet_count()));
    ctx.count("tetra.nodes", static_cast<double>(mesh.node_count()));
    ctx.count("tetra.regions", static_cast<double>(labels.size()));
    ctx.count("tetra.remeshings", static_cast<double>(remeshes));
    ctx.count("tetra.closing_rounds", static_cast<double>(closing_rounds));
    ctx.count("tetra.closing_tets", static_cast<double>(closing_tets));
    ctx.count("tetra.max_levels", static_cast<double>(levels));
    ctx.info("tetra: " + std::to_string(mesh.tet_count()) + " tets, " +
             std::to_string(mesh.node_count()) + " nodes, " + std::to_string(labels.size()) +
             " regions, " + std::to_string(remeshes) + " local remeshings");
    return mesh;
}

}  // namespace frontmesh::volume
