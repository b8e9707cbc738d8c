#pragma once
// The local operations of the refine stage (§3.3) on a TetTopology, exposed for the tests:
// node removal, angle-based smoothing, flips (edge suppression n -> m, 2 -> 3) and the sliver
// pass's node moves. Every change is validated with exact orientation tests and never crosses a
// wall (boundary/interface face or region change). Sequential and deterministic.

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "volume/refine.h"
#include "volume/tet_topology.h"

namespace frontmesh::volume {

/// What a local change minimises: the largest value over the tets it touches.
enum class Objective {
    Skewness,  ///< Eq. 1 (the paper's criterion)
    Combined,  ///< max(skewness, 1 - min dihedral / 70.53 deg): slivers and caps alike; on a
               ///< poor input triangle (TetTopology::is_poor_face) the dihedral term alone;
               ///< a tet under kSliverFloorDeg costs 1 more (combined_cost)
};

/// Skewness (Eq. 1) and smallest dihedral angle (degrees, when asked) of a tet; a nearly flat
/// tet (normalised volume below 1e-6) reports skewness 1 and dihedral 0.
struct TetShape {
    double skewness = 1.0;
    double min_dihedral_deg = 0.0;
};
TetShape tet_shape(const double* a, const double* b, const double* c, const double* d,
                   bool dihedral);

/// Cost of tet t (nodes of `topo`) under `objective`: 0 ideal, 1 degenerate (Combined: up to
/// 2, see combined_cost).
double tet_cost(const TetTopology& topo, const Tet& t, Objective objective);

/// Smallest dihedral angle (degrees) under which the Combined objective ranks a tet behind
/// every tet above it, whatever their skewness.
inline constexpr double kSliverFloorDeg = 10.0;

/// The Combined cost of a tet of shape `s` (dihedral angle measured); `poor_face`: it has a
/// poor input triangle, and its dihedral term alone counts (its skewness stays high whatever
/// is done). A sliver under kSliverFloorDeg costs 1 + that, more than any cap: otherwise a
/// change that trades a 1 deg sliver for a cap of skewness 0.997 and 14 deg (the sliver
/// rescue of insert_node) is undone at once by a move, flip or node removal that lowers the
/// largest cost back to the sliver's 0.984 (natbrainlab near (17.8, -87.0, 97.9) mm).
inline double combined_cost(const TetShape& s, bool poor_face) {
    const double dihedral_cost = 1.0 - s.min_dihedral_deg / 70.528779365509308;  // arccos(1/3)
    const double cost = poor_face ? dihedral_cost : std::max(s.skewness, dihedral_cost);
    return s.min_dihedral_deg < kSliverFloorDeg ? 1.0 + cost : cost;
}

/// Counts of changes made.
struct RefineCounts {
    std::size_t nodes_removed = 0;
    std::size_t smoothing_moves = 0;
    std::size_t flips_2_3 = 0, flips_3_2 = 0, flips_4_4 = 0, flips_n_m = 0;
    std::size_t sliver_flips = 0, sliver_moves = 0, sliver_removals = 0, sliver_insertions = 0;
    std::size_t sliver_sweeps =
        0;  ///< sweeps the sliver pass made (it stops at one that changes nothing)
    std::size_t edge_splits = 0;                    ///< tetra.max_edge_length
    std::size_t flip_attempts = 0, edge_rings = 0;  ///< work done (tets examined, rings walked)
};

class RefineOps {
public:
    RefineOps(TetTopology& topo, const RefineParams& params) : topo_(topo), params_(params) {}

    RefineCounts counts;

    /// Tests only: accept any valid change (no quality criterion), to check the mechanics.
    void set_unconditional(bool on) { unconditional_ = on; }

    /// §3.3.1: unconditional removal of interior nodes with small stars.
    void remove_nodes();

    /// §3.3.2: one Gauss-Seidel sweep of angle-based smoothing over interior nodes (id order).
    void smooth();

    /// §3.3.3: flips around tets with skewness > flip_skewness, worst first.
    void flips();

    /// Beyond the paper: slivers (small dihedral) and remaining caps, worst first: flips with the
    /// combined objective, then moves of their interior nodes, then conditional node removal,
    /// then a Steiner node (insert_node).
    void slivers();

    /// Alive tets costing more than `threshold`, worst first (ties by id). A repeated call with
    /// the same objective and threshold measures only the tets changed since.
    std::vector<std::int32_t> bad_tets(Objective objective, double threshold) const;

    double max_cost(std::span<const std::int32_t> tets, Objective objective) const;

    /// Shape of alive tet t (tet_shape; the dihedral angle only when `dihedral`), cached per tet
    /// until this object changes t; any edit of the topology made elsewhere (its stamp())
    /// drops the whole cache. Thread-safe for distinct tets after prepare_cache().
    TetShape shape(std::int32_t t, bool dihedral) const;
    /// tet_cost of alive tet t through the cache.
    double cost(std::int32_t t, Objective objective) const;
    /// Sizes the shape cache for every tet id, dropping it after an edit made elsewhere (call
    /// before shape() from several threads).
    void prepare_cache() const;

    /// Removes interior node v when its star has at most `max_tets` tets and the hole can be
    /// filled by a fan from one of its link nodes (all new tets positive, exact). The fan with
    /// the smallest largest cost is used; with `conditional` only when that beats the star.
    bool remove_node(std::int32_t v, int max_tets, Objective objective, bool conditional);

    /// The angle-based target of node v (Zhou & Shimada, extended to 3-D): for each neighbour
    /// N_j, the direction from N_j is rotated onto the axis of the cone of nodes around edge
    /// (N_j, v) (the 3-D analogue of the angle bisector), keeping |N_j v|; the mean is the target.
    Eigen::Vector3d angle_based_target(std::int32_t v);

    /// Largest cost and the cost sum of the star of v (star_, as left by collect_link's caller)
    /// with v at p; the mesh is not changed. +inf when a tet would not be strictly positive
    /// (exact), or as soon as a tet's cost exceeds `bound` (the sum is then partial).
    std::pair<double, double> star_cost(std::int32_t v, const Eigen::Vector3d& p,
                                        Objective objective,
                                        double bound = std::numeric_limits<double>::infinity());

    void collect_link(std::int32_t v);

    bool smooth_node(std::int32_t v);

    /// Sliver pass: moves interior node v (local index i of the sliver `sliver`) to the best of
    /// a few candidates (angle-based target, away from its opposite face, fixed pseudo-random
    /// offsets) when that lowers the combined cost of its star.
    bool move_node(std::int32_t v, const Tet& sliver, int i);

    /// Edge suppression: removes edge (a, b) (around tet t) and fills its ring polygon with the
    /// triangulation minimising the largest cost (dynamic programming over the polygon); kept only
    /// when that beats the ring's current largest cost. 3 -> 2, 4 -> 4, n -> 2n - 4.
    bool remove_edge(std::int32_t a, std::int32_t b, std::int32_t t, Objective objective);

    /// Beyond the paper: a new interior node for tet t, for the tets no flip, move or removal
    /// mends (typically all four nodes on the input surface: nothing of them can move). The
    /// cavity is t and the tets across its non-wall faces (then also the tets across theirs),
    /// when its boundary is a sphere; the node goes to the best of a few positions (ideal apexes
    /// of t's faces, centroids, a small deterministic search) and is joined to every boundary
    /// face, so the walls and the input triangles stay. Kept when every new tet is strictly
    /// positive (exact) and the largest cost falls (never more tets above skewness 0.8).
    bool insert_node(std::int32_t t, Objective objective);

    /// tetra.max_edge_length: splits interior edge (a, b) (around tet t) at its midpoint m:
    /// each tet (a, b, r_k, r_k+1) of its ring becomes (m, b, r_k, r_k+1) and (a, m, r_k,
    /// r_k+1). False, with nothing changed, when the edge lies on a wall (its ring is open) or
    /// a new tet would not be strictly positive (exact).
    bool split_edge(std::int32_t a, std::int32_t b, std::int32_t t);

    /// Splits the interior edges longer than their cap, longest first (ties by node ids), in
    /// rounds until none is left or kMaxSplitRounds rounds ran; returns how many such edges
    /// are left (walls excluded: the input surface is kept). The cap of edge (a, b) is
    /// `max_length` (mm), or the longest input-surface edge at a or b when that is longer:
    /// a tet on a surface triangle larger than the cap keeps edges of about its size.
    std::size_t split_long_edges(double max_length);
    static constexpr int kMaxSplitRounds = 32;

    /// tetra.max_edge_length: from this call on, every change (flip, node removal, move,
    /// smoothing, new node) is kept only when the edges it makes or moves are within their
    /// cap (split_long_edges' cap for `max_length` mm), so the quality passes after the splits
    /// cannot make long edges again. 0 (the default) means no cap and changes nothing.
    /// O(input triangles).
    void set_edge_cap(double max_length);
    /// Whether edge (a, b), with its nodes at pa and pb, is within the cap (always true without
    /// one); a or b may be -1 for a node not added yet (interior: the cap is max_length).
    bool is_within_cap(std::int32_t a, const double* pa, std::int32_t b, const double* pb) const;
    /// Whether every edge of tet t (node ids of the topology) is within the cap.
    bool is_within_cap(const Tet& t) const;

    /// 2 -> 3: face i of tet t and the tet across it become three tets around the new edge AB.
    bool flip_2_3(std::int32_t t, int i, Objective objective);

    /// §3.3.3 steps 2-3 for tet t: nodes A by descending area of the opposite face F; edge
    /// suppression on the edges of F first, then the 2 -> 3 swap of F. True when t was replaced.
    bool improve_by_flips(std::int32_t t, Objective objective, bool delaunay_test);

private:
    /// insert_node's cavity `variant` around tet t into cavity_: 0-5 the ring of edge
    /// `variant` of t (false when that edge lies on a wall), 6 and 7 t with one and two layers
    /// of neighbours across non-wall faces, 8-11 the star of node `variant` - 8 of t (false
    /// when it is a surface node): the new node replaces it, a move searched widely.
    bool insertion_cavity(std::int32_t t, int variant);
    /// Replaces the tets `cavity` by a new node at p joined to every face of `boundary` (faces
    /// seen from inside), in `region`; the node's level is the highest of the cavity's nodes.
    void fill_cavity(std::span<const std::int32_t> cavity,
                     std::span<const std::array<std::int32_t, 3>> boundary,
                     const Eigen::Vector3d& p, core::Label region);
    /// smooth_node with the closed star of v already in star_.
    bool smooth_star(std::int32_t v);
    /// Replaces tets through the topology and marks the new tets, their neighbours and nodes
    /// as changed.
    void apply(std::span<const std::int32_t> old_tets, std::span<const Tet> new_tets,
               core::Label region);
    /// Forgets that `tets` (and their neighbours and nodes) were tried without success.
    void changed_tets(std::span<const std::int32_t> tets);
    /// changed_tets(star_) after node v (star star_, link link_) moved.
    void moved_node(std::int32_t v);

    TetTopology& topo_;
    RefineParams params_;
    bool unconditional_ = false;
    std::vector<std::int32_t> star_, link_, ring_tets_, ring_, cavity_;
    std::vector<Tet> candidate_, best_;
    std::vector<std::int32_t> new_ids_;
    std::vector<Eigen::Vector3d> axes_;
    std::vector<std::uint8_t> settled_;  ///< per tet: flips tried, nothing found
    /// Per tet: cached shape (shape()); `known` says which parts are valid. 24 MB per million
    /// tets.
    struct CachedShape {
        double skewness = 1.0;
        double min_dihedral_deg = 0.0;
        std::uint8_t known = 0;  ///< kSkewness | kDihedral | kOrientation | kPositive bits
    };
    static constexpr std::uint8_t kSkewness = 1, kDihedral = 2, kOrientation = 4, kPositive = 8;
    mutable std::vector<CachedShape> cache_;
    mutable std::uint64_t cache_stamp_ = ~std::uint64_t{0};  ///< topo_.stamp() the cache matches
    /// Forgets the cached shapes of `tets` (just changed here) and takes the topology's stamp.
    void edited(std::span<const std::int32_t> tets);
    /// Records that the shapes of `tets` changed (for bad_tets' list).
    void touch(std::span<const std::int32_t> tets);
    /// bad_tets' last list (cost, tet; worst first) for bad_objective_ and bad_threshold_, and
    /// the tets changed since (touched_, marked in touched_mark_): the next call redoes only
    /// those. 16 MB per million listed tets.
    mutable std::vector<std::pair<double, std::int32_t>> bad_list_;
    mutable bool bad_valid_ = false;
    mutable Objective bad_objective_ = Objective::Skewness;
    mutable double bad_threshold_ = 0.0;
    mutable std::vector<std::int32_t> touched_;
    mutable std::vector<std::uint8_t> touched_mark_;
    /// Whether alive tet t is strictly positive (exact), cached with its shape.
    bool is_positive(std::int32_t t) const;
    /// Skewness of each star_ tet from the last star_cost() (kept moves store it in the cache).
    std::vector<double> trial_skewness_;
    /// Per node: its index in link_ while collect_link's link is current, else -1.
    std::vector<std::int32_t> link_slot_;
    std::vector<std::int32_t> slotted_;  ///< the nodes whose link_slot_ is set
    std::vector<std::array<std::int32_t, 3>>
        star_slots_;  ///< per star_ tet: link slots of its other nodes
    std::vector<Eigen::Vector3d> link_xyz_;
    /// smooth(): node -> alive tets (CSR, tets in id order) and nodes on a wall face.
    std::vector<std::int32_t> star_offset_, star_tets_;
    std::vector<std::uint8_t> on_wall_;
    std::vector<std::uint8_t> node_settled_;  ///< per node: smoothing tried, no move kept
    /// set_edge_cap: the cap squared (0: none) and, per input-surface node, its longest input
    /// edge squared. 8 MB per million surface nodes.
    double cap2_ = 0.0;
    std::vector<double> surface_edge2_;
    /// Fills surface_edge2_ (once).
    void index_surface_edges();
    /// Whether edge (a, b) at pa, pb is within the local cap for a cap of sqrt(max2) mm.
    bool is_within(std::int32_t a, const double* pa, std::int32_t b, const double* pb,
                   double max2) const;
};

}  // namespace frontmesh::volume
