#pragma once
// The mesher of one region in the tetra stage (volume/tetra.h): the data of §3.1.1 and the
// steps of the paper's method as member functions. Internal to the stage: the method itself
// is volume/tetra.cpp, the closing phase, the end of a region and the merge of the regions
// volume/tetra_region.cpp, the front volume/tetra_front.h, the exact validity test
// volume/tet_validity.h.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/adt.h"
#include "pipeline/core/huge_pages.h"
#include "pipeline/core/stage_context.h"
#include "pipeline/core/surface_network.h"
#include "pipeline/core/tet_mesh.h"
#include "volume/tet_validity.h"
#include "volume/tetra.h"
#include "volume/tetra_front.h"

namespace frontmesh::volume::detail {

using core::Label;
using V3 = Eigen::Vector3d;
using Tet = std::array<std::int32_t, 4>;

inline constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// Outward faces of a VTK-positive tet (v0, v1, v2, v3): the right-hand normal of each points
// away from the opposite vertex.
inline constexpr int kTetFace[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};

/// Counters of a region's run, reported as `tetra.<name>` (kStatNames).
enum Stat {
    kBasesTried,
    kBasesFailed,
    kRejectedByTests,  // the paper's quality tests of step 4
    kInvalid,          // the exact validity test
    kOnExistingNodes,
    kOnNewNodes,
    kStage1Tets,  // §3.1.4
    kStage2Tets,  // §3.1.5
    kStatCount
};
inline constexpr const char* kStatNames[kStatCount] = {"bases_tried",
                                                       "bases_failed",
                                                       "candidates_rejected_by_tests",
                                                       "candidates_invalid",
                                                       "tets_on_existing_nodes",
                                                       "tets_on_new_nodes",
                                                       "stage1_tets",
                                                       "stage2_tets"};

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
    std::int64_t cones = 0;    // cavities filled by the completion path
    std::int32_t attempt = 0;  // 0: the first; more: meshed again after a failure (tetra())
    std::int32_t levels = 0;
    std::int64_t stat[kStatCount] = {};
};

/// The order of the closing phase after the levels: the relaxed fill, then the closing rounds
/// that remove rings of tets and re-advance, then the completion path (rings_first); or one
/// completion round right after the relaxed fill (cones_first), then the same.
enum class ClosingOrder { rings_first, cones_first };

/// What a region's mesher uses of the stage context from its worker thread: log lines and
/// diagnostics go through one lock, the cancellation check needs none.
class RegionSink {
public:
    RegionSink(core::StageContext& ctx, std::mutex& mutex) : ctx_(ctx), mutex_(mutex) {}
    void debug(const std::string& message) const {
        std::lock_guard<std::mutex> lock(mutex_);
        ctx_.debug(message);
    }
    void info(const std::string& message) const {
        std::lock_guard<std::mutex> lock(mutex_);
        ctx_.info(message);
    }
    void check_cancelled() const { ctx_.check_cancelled(); }
    bool wants_diagnostics() const { return ctx_.wants_diagnostics(); }
    void diagnose(core::Diagnostic diagnostic) const {
        std::lock_guard<std::mutex> lock(mutex_);
        ctx_.diagnose(std::move(diagnostic));
    }

private:
    const core::StageContext& ctx_;
    std::mutex& mutex_;
};

/// The layered advancing front of §3.1-3.2 for one region.
///
/// Memory per million elements: nodes 24 B xyz + 48 B attributes + 12 B validity scratch +
/// about 100 B in the node ADT while on the front; front faces 77 B + about 100 B in the face
/// ADT (volume/tetra_front.h); tets 16 B + 16 B links + 5 B. About 0.1 GB per million tets in
/// all (Colin27: 557k tets, 132 MB peak for the whole run).
class RegionMesher {
public:
    RegionMesher(const core::SurfaceNetwork& surface, Label region, const TetraParams& params,
                 const RegionSink& sink)
        : params_(params), region_(region), sink_(sink), front_(xyz_, domain_of(surface, region)) {
        init_front(surface);
    }

    /// Meshes the region (once per mesher); throws MeshingError when its front cannot be
    /// closed, after handing the open front to the diagnostics sink on the last attempt.
    RegionResult run(ClosingOrder order, bool last_attempt);

private:
    // ---- §3.1.1 required data ------------------------------------------------------------
    const TetraParams params_;
    const Label region_;
    const RegionSink& sink_;
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
    core::HugeVector<std::int32_t> tet_head_;      // first corner 4 t + c of the node's tets
    core::HugeVector<std::int32_t> mark_;          // scratch stamps
    std::int32_t mark_value_ = 0;

    // the front triangles (normal into the unmeshed part of the region), the ADTs
    Front front_;
    TetValidity validity_;  // the exact test of step 4, with its per-node scratch

    // tetrahedra
    core::HugeVector<Tet> tv_;
    core::HugeVector<std::int32_t> tnext_;   // 4 per tet
    core::HugeVector<std::int32_t> tfront_;  // front number at creation
    core::HugeVector<std::uint8_t> talive_;
    std::int64_t alive_tets_ = 0;

    // run state
    std::int32_t front_no_ = 0;
    std::int64_t remeshes_ = 0;
    std::int64_t remesh_budget_ = 0;
    std::int64_t max_front_ = 0;           // a front this large has degenerated (init_front)
    std::vector<std::int32_t> new_faces_;  // faces added by the last add/remove
    std::vector<std::int32_t> visible_faces_;
    std::vector<std::int32_t> near_faces_;  // front faces of the current base's search box
    std::vector<std::int32_t> node_ids_;    // scratch: ADT query results
    struct Cand {
        double key0, key1;
        std::int32_t id;
    };
    std::vector<Cand> cands_;  // candidates of the current base
    std::int64_t stat_[kStatCount] = {};

    // ---- the base of a try (§3.1.4) --------------------------------------------------------
    /// One front face at a base node a_i, copied with what the tests of step 4 read: the
    /// face, its other two nodes u, w in cyclic order (the face is (a_i, u, w)), their
    /// positions and the unit normal. make_base copies the three stars once; every
    /// candidate's tests then read them from one small array instead of walking the node->face
    /// lists and the node and face arrays again (the front does not change before try_base
    /// returns).
    struct StarFace {
        std::int32_t f, u, w;
        V3 U, W, n;
    };
    struct Base {
        std::int32_t f = -1;
        std::int32_t a[3] = {-1, -1, -1};
        V3 A[3];
        V3 n;                                       // unit normal N_k
        double area = 0;                            // a_k
        double h = 0;                               // h_k, Eq. 8
        double eta = 0;                             // Eq. 2
        V3 xm, xo, xc;                              // centre, reference point, Eq. 11 centre
        double max_b = 0;                           // max |x_ck B_ki|
        std::int32_t star_begin[4] = {0, 0, 0, 0};  // star of a_i: stars_[star_begin[i], [i + 1])
        std::int32_t wing_begin[4] = {0, 0, 0, 0};  // wings of edge a_i a_j: wings_[...]
        std::int32_t edge_begin[4] = {0, 0, 0, 0};  // front edges at a_i: edges_[...]
        V3 e[3];  // unit direction of the base edge a_i a_j (j = i + 1 mod 3)
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
    /// The candidate search of one base (§3.1.4 steps 3-4).
    struct Search {
        bool relaxed;      // closing phase: the paper's quality filters dropped
        bool small_front;  // relaxed with at most 64 front faces: every face is near
        double r1;         // Eq. 11 radius for w = 1
        double min_vol;    // relaxed volume test
        core::AdtBox base_box;
        // near_faces_ holds every front face whose box meets `fetched`: those a validity
        // test of a tet (base, q) with q inside `fetched` needs; with `near_ready` every
        // front face
        core::AdtBox fetched;
        bool near_ready = false;
        V3 centroid = V3::Zero();  // of the relaxed candidates
        int ncent = 0;
    };

    // ---- small helpers --------------------------------------------------------------------
    static core::AdtBox domain_of(const core::SurfaceNetwork& s, Label r);
    const double* p(std::int32_t v) const { return &xyz_[3 * static_cast<std::size_t>(v)]; }
    V3 x(std::int32_t v) const { return V3(p(v)[0], p(v)[1], p(v)[2]); }
    V3 node_normal(std::int32_t v) const {
        return V3(normal_[3 * v], normal_[3 * v + 1], normal_[3 * v + 2]);
    }
    std::int32_t node_count() const { return static_cast<std::int32_t>(level_.size()); }
    std::int32_t next_mark();
    std::string where(std::int32_t v) const;
    std::int32_t push_node(const V3& q, std::int32_t level);
    void pop_node();

    // ---- the method, in the paper's order ---------------------------------------------------
    std::int32_t mesh_levels();
    void init_front(const core::SurfaceNetwork& surface);
    // §3.1.3
    struct LevelSetup;
    void setup_level();
    void estimate_spacing(LevelSetup& s);
    void correct_by_influence(LevelSetup& s);
    void smooth_heights(const std::vector<std::int32_t>& front_nodes);
    bool is_visible(std::int32_t j, std::int32_t i);
    /// h_o of Eq. 4 for the mean area `mean_area` of a node's faces (mm^2).
    double reference_height(double mean_area) const {
        return 1.24 * params_.stretching * std::sqrt(mean_area);
    }
    // §3.1.4 / §3.1.5
    bool is_active(std::int32_t v) const { return setup_stamp_[v] == front_no_; }
    bool is_eligible(std::int32_t f, int stage) const {
        const Tri& t = front_.face(f).v;
        const int n = is_active(t[0]) + is_active(t[1]) + is_active(t[2]);
        return stage == 1 ? n == 3 : n >= 1;
    }
    void run_stage(int stage, bool allow_remesh);
    Base make_base(std::int32_t f, bool active_only);
    void copy_stars(Base& bk);
    void base_height(Base& bk, bool active_only) const;
    void new_point_frame(Base& bk) const;
    bool try_base(std::int32_t f, bool active_only, bool relaxed);
    void collect_candidates(const Base& bk, Search& s, double rmin, double r, bool from_faces);
    void order_candidates(const Base& bk, const Search& s);
    void ensure_near(Search& s, std::int32_t q);
    bool try_existing(const Base& bk, Search& s, std::int32_t q);
    bool try_new(const Base& bk, Search& s, const V3& P);
    // step 4
    bool passes_paper_tests(const Base& bk, std::int32_t q) const;
    bool passes_new_edge_tests(const Base& bk, int i, const V3& P) const;
    bool passes_new_face_tests(const Base& bk, int i, std::int32_t q, const V3& P) const;
    bool is_valid_tet(const Base& bk, std::int32_t q, const std::vector<std::int32_t>& near);
    bool has_tet_with(std::int32_t a, std::int32_t b, std::int32_t c) const;
    // step 5, §3.2
    void add_tet(std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t d);
    void remove_tet(std::int32_t t);
    bool remesh_around(std::int32_t f);
    // closing phase
    std::int64_t close_cavities(std::int32_t first, std::int32_t last);
    void closing_round(std::int32_t rings);
    void remove_rings(std::int32_t rings);
    void remove_rings_at(std::vector<std::int32_t> nodes, std::int32_t rings);
    void fill_relaxed();
    // completion path
    /// At most this many completion rounds per region: a round tries every cavity once; a
    /// cavity that fails grows by a ring of tets before the next round. The count of rounds is
    /// the bound.
    static constexpr std::int32_t kCompletionRounds = 4;
    std::int64_t complete_cavities(std::int32_t rounds);
    std::vector<std::vector<std::int32_t>> front_cavities() const;
    bool fill_star(const std::vector<std::int32_t>& cavity);
    /// At most this many rounds of partial cones (split_cavities) per region: each round
    /// adds a tet or is the last. The count of rounds is the bound.
    static constexpr std::int32_t kSplitRounds = 32;
    bool fill_partial(const std::vector<std::int32_t>& cavity);
    std::int64_t split_cavities(std::int32_t rounds);
    std::vector<std::int32_t> front_cavity_of(std::int32_t g) const;
    std::int32_t tet_behind(std::int32_t a, std::int32_t b, std::int32_t c) const;
    bool grow_star(const std::vector<std::int32_t>& cavity, const V3& P,
                   std::vector<std::int32_t>& grown, std::vector<Tri>& faces) const;
    bool cone_from(const V3& P, const std::vector<std::int32_t>& grown,
                   const std::vector<Tri>& faces);
    Search relaxed_search(const Base& bk) const;
    // the end
    void diagnose_open_front() const;
    RegionResult result() const;
    [[noreturn]] void fail(const std::string& why) const;
};

inline std::int32_t RegionMesher::next_mark() {
    if (++mark_value_ == std::numeric_limits<std::int32_t>::max()) {
        std::fill(mark_.begin(), mark_.end(), 0);
        mark_value_ = 1;
    }
    return mark_value_;
}

inline std::int32_t RegionMesher::push_node(const V3& q, std::int32_t level) {
    xyz_.insert(xyz_.end(), {q.x(), q.y(), q.z()});
    level_.push_back(level);
    setup_stamp_.push_back(-1);
    normal_.insert(normal_.end(), {0.0, 0.0, 0.0});
    h_.push_back(0.0);
    rs_.push_back(0.0);
    remesh_count_.push_back(0);
    tet_head_.push_back(-1);
    mark_.push_back(0);
    front_.add_node();
    validity_.resize(level_.size());
    return node_count() - 1;
}

inline void RegionMesher::pop_node() {
    xyz_.resize(xyz_.size() - 3);
    level_.pop_back();
    setup_stamp_.pop_back();
    normal_.resize(normal_.size() - 3);
    h_.pop_back();
    rs_.pop_back();
    remesh_count_.pop_back();
    tet_head_.pop_back();
    mark_.pop_back();
    front_.pop_node();
    validity_.resize(level_.size());
}

/// The deterministic merge of the regions' results (in label order) into the stage's mesh,
/// with the stage's counters and summary line.
core::TetMesh merge_regions(const core::SurfaceNetwork& surface,
                            const std::vector<RegionResult>& results, core::StageContext& ctx);

}  // namespace frontmesh::volume::detail
