#include "volume/refine_ops.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/quality.h"
#include "volume/refine_ops_shared.h"

// §3.3.2 angle-based node smoothing, and the node moves of the sliver pass.

namespace frontmesh::volume {

using namespace refine_detail;

/// §3.3.2: one Gauss-Seidel sweep of angle-based smoothing over interior nodes (id order).
void RefineOps::smooth() {
    node_settled_.resize(static_cast<std::size_t>(topo_.node_capacity()), 0);
    // Smoothing changes no connectivity: the stars come from one node -> tets table (tets in id
    // order) instead of a walk per node. A node on a wall face has no closed star.
    const auto n_nodes = static_cast<std::size_t>(topo_.node_capacity());
    star_offset_.assign(n_nodes + 1, 0);
    on_wall_.assign(n_nodes, 0);
    for (std::int32_t t = 0; t < topo_.tet_capacity(); ++t) {
        if (!topo_.alive(t)) continue;
        const Tet& tt = topo_.tet(t);
        for (int i = 0; i < 4; ++i) {
            ++star_offset_[static_cast<std::size_t>(tt[static_cast<std::size_t>(i)]) + 1];
            if (topo_.neighbor(t, i) < 0)
                for (const std::int32_t w : tet_face(tt, i))
                    on_wall_[static_cast<std::size_t>(w)] = 1;
        }
    }
    for (std::size_t v = 0; v < n_nodes; ++v) star_offset_[v + 1] += star_offset_[v];
    star_tets_.resize(static_cast<std::size_t>(star_offset_[n_nodes]));
    {
        std::vector<std::int32_t> fill(star_offset_.begin(), star_offset_.end() - 1);
        for (std::int32_t t = 0; t < topo_.tet_capacity(); ++t) {
            if (!topo_.alive(t)) continue;
            for (const std::int32_t w : topo_.tet(t))
                star_tets_[static_cast<std::size_t>(fill[static_cast<std::size_t>(w)]++)] = t;
        }
    }
    for (std::int32_t v = topo_.mesh().surface_vertices; v < topo_.node_capacity(); ++v) {
        const auto k = static_cast<std::size_t>(v);
        if (star_offset_[k] == star_offset_[k + 1] || node_settled_[k]) continue;
        bool moved = false;
        if (!on_wall_[k]) {
            star_.assign(star_tets_.begin() + star_offset_[k],
                         star_tets_.begin() + star_offset_[k + 1]);
            moved = smooth_star(v);
        }
        if (moved)
            ++counts.smoothing_moves;
        else
            node_settled_[k] = 1;  // until its star changes
    }
    std::vector<std::int32_t>().swap(
        star_tets_);  // stale after the next edit; 16 MB per million tets
}

/// The angle-based target of node v (Zhou & Shimada, extended to 3-D): for each neighbour
/// N_j, the direction from N_j is rotated onto the axis of the cone of nodes around edge
/// (N_j, v) (the 3-D analogue of the angle bisector), keeping |N_j v|; the mean is the target.
Eigen::Vector3d RefineOps::angle_based_target(std::int32_t v) {
    // For a closed star every node r around edge (v, N_j) lies in exactly two star tets (the
    // two sharing face (v, N_j, r)), so summing over the star tets' link-node pairs weights each
    // ring node twice: the axis direction is unchanged.
    const V3 pv = topo_.point(v);
    axes_.assign(link_.size(), V3::Zero());
    link_xyz_.resize(link_.size());
    for (std::size_t k = 0; k < link_.size(); ++k) link_xyz_[k] = topo_.point(link_[k]);
    for (const auto& others : star_slots_)  // the link slots of each star tet's other nodes
        for (int x = 0; x < 3; ++x)
            for (int y = x + 1; y < 3; ++y) {
                const auto j = static_cast<std::size_t>(others[static_cast<std::size_t>(x)]);
                const auto r = static_cast<std::size_t>(others[static_cast<std::size_t>(y)]);
                V3 u = link_xyz_[r] - link_xyz_[j];
                const double length = u.norm();
                if (length == 0.0) continue;
                u /= length;
                axes_[j] += u;
                axes_[r] -= u;
            }
    V3 sum = V3::Zero();
    for (std::size_t k = 0; k < link_.size(); ++k) {
        const V3& pj = link_xyz_[k];
        const V3& axis = axes_[k];
        const V3 jv = pv - pj;
        const double length = jv.norm();
        const double axis_length = axis.norm();
        V3 direction =
            axis_length > 1e-9 * (length + 1e-300) ? V3(axis / axis_length) : V3(jv / length);
        if (direction.dot(jv) < 0.0) direction = -direction;
        sum += pj + length * direction;  // N_j rotated onto the cone axis, |N_j v| kept
    }
    return link_.empty() ? pv : V3(sum / static_cast<double>(link_.size()));
}

/// Largest cost and the cost sum of the star of v with v at p; +inf when a tet would not be
/// strictly positive (exact) or an edge at v would exceed the tetra.max_edge_length cap.
std::pair<double, double> RefineOps::star_cost(std::int32_t v, const V3& p, Objective objective,
                                               double bound) {
    // v's coordinates replaced by p in each tet, without moving v: nothing to restore, and the
    // cached shapes of the star stay valid.
    trial_skewness_.clear();
    double worst = 0.0, sum = 0.0;
    for (const std::int32_t t : star_) {
        const Tet& tt = topo_.tet(t);
        std::array<const double*, 4> x{};
        for (int k = 0; k < 4; ++k) {
            const std::int32_t w = tt[static_cast<std::size_t>(k)];
            x[static_cast<std::size_t>(k)] = w == v ? p.data() : topo_.xyz(w);
        }
        // The cost first: above `bound` the answer is +inf whether or not t is positive.
        const TetShape s = tet_shape(x[0], x[1], x[2], x[3], objective == Objective::Combined);
        double c = s.skewness;
        if (objective == Objective::Combined) c = combined_cost(s, topo_.has_poor_face(tt));
        bool within_cap = true;  // tetra.max_edge_length: v's edges at p
        for (int k = 0; k < 4 && within_cap && cap2_ > 0.0; ++k) {
            const std::int32_t w = tt[static_cast<std::size_t>(k)];
            if (w != v) within_cap = is_within_cap(v, p.data(), w, topo_.xyz(w));
        }
        if (c > bound || !within_cap || !positive_tet(x[0], x[1], x[2], x[3])) {
            worst = kInf;
            break;
        }
        trial_skewness_.push_back(s.skewness);
        worst = std::max(worst, c);
        sum += c;
    }
    return {worst, sum};
}

void RefineOps::collect_link(std::int32_t v) {
    if (link_slot_.size() < static_cast<std::size_t>(topo_.node_capacity()))
        link_slot_.resize(static_cast<std::size_t>(topo_.node_capacity()), -1);
    for (const std::int32_t w : slotted_) link_slot_[static_cast<std::size_t>(w)] = -1;
    slotted_.clear();
    link_.clear();
    star_slots_.clear();
    for (const std::int32_t t : star_) {
        std::array<std::int32_t, 3> others{};
        int k = 0;
        for (const std::int32_t w : topo_.tet(t)) {
            if (w == v) continue;
            if (link_slot_[static_cast<std::size_t>(w)] < 0) {
                link_slot_[static_cast<std::size_t>(w)] = static_cast<std::int32_t>(link_.size());
                link_.push_back(w);
            }
            if (k < 3)
                others[static_cast<std::size_t>(k++)] = link_slot_[static_cast<std::size_t>(w)];
        }
        star_slots_.push_back(others);
    }
    slotted_ = link_;
}

bool RefineOps::smooth_node(std::int32_t v) {
    if (!topo_.star(v, star_)) return false;
    return smooth_star(v);
}

bool RefineOps::smooth_star(std::int32_t v) {
    prepare_cache();
    // The star's current costs from the cache (same order and sum as star_cost at p0).
    double old_worst = 0.0, old_sum = 0.0;
    for (const std::int32_t t : star_) {
        if (!is_positive(t)) {
            old_worst = kInf;
            break;
        }
        const double c = shape(t, false).skewness;
        old_worst = std::max(old_worst, c);
        old_sum += c;
    }
    if (old_worst <= params_.smoothing_skewness) return false;  // star good enough already
    collect_link(v);
    const V3 p0 = topo_.point(v);
    const V3 target = angle_based_target(v);
    for (const double s : {1.0, 0.5, 0.25}) {
        const V3 p = p0 + s * (target - p0);
        const auto [worst, sum] = star_cost(v, p, Objective::Skewness, old_worst);
        // The worst incident quality must not get worse, and the star must gain overall.
        if (worst <= old_worst && sum < old_sum) {
            topo_.set_point(v, p);
            moved_node(v);
            // The shapes just computed at p are the star's new shapes (all positive).
            for (std::size_t k = 0; k < star_.size(); ++k)
                cache_[static_cast<std::size_t>(star_[k])] = {trial_skewness_[k], 0.0,
                                                              kSkewness | kOrientation | kPositive};
            cache_stamp_ = topo_.stamp();
            touch(star_);
            return true;
        }
    }
    return false;
}

/// Sliver pass: moves interior node v (local index i of the sliver `sliver`) to the best of
/// a few candidates (angle-based target, away from its opposite face, fixed pseudo-random
/// offsets) when that lowers the combined cost of its star.
bool RefineOps::move_node(std::int32_t v, const Tet& sliver, int i) {
    if (!topo_.star(v, star_)) return false;
    collect_link(v);
    const V3 p0 = topo_.point(v);
    double h = 0.0;
    for (const std::int32_t w : link_) h += (topo_.point(w) - p0).norm();
    h /= static_cast<double>(link_.size());
    const auto f = tet_face(sliver, i);  // outward: v lies on the side opposite its normal
    V3 n = (topo_.point(f[1]) - topo_.point(f[0])).cross(topo_.point(f[2]) - topo_.point(f[0]));
    if (n.norm() > 0.0) n = -n.normalized();
    std::vector<V3> candidates;
    const V3 target = angle_based_target(v);
    for (const double s : {1.0, 0.5, 0.25}) candidates.push_back(p0 + s * (target - p0));
    for (const double s : {0.4, 0.2, 0.1, 0.05}) candidates.push_back(p0 + s * h * n);
    // Fixed offsets (a deterministic function of v): a small random search.
    OffsetSequence offsets(v);
    auto next = [&]() { return offsets.next(); };
    for (int k = 0; k < 12; ++k) {
        V3 d(next(), next(), next());
        if (d.norm() < 1e-6) continue;
        candidates.push_back(p0 + (k < 6 ? 0.2 : 0.07) * h * d.normalized());
    }
    const auto [old_worst, old_sum] = star_cost(v, p0, Objective::Combined);
    double best_worst = old_worst, best_sum = old_sum;
    int best = -1;
    for (std::size_t k = 0; k < candidates.size(); ++k) {
        const auto [worst, sum] = star_cost(v, candidates[k], Objective::Combined, best_worst);
        if (worst < best_worst || (worst == best_worst && sum < best_sum && best >= 0)) {
            best_worst = worst;
            best_sum = sum;
            best = static_cast<int>(k);
        }
    }
    if (best < 0 || !(best_worst < old_worst)) return false;
    {
        std::size_t before = 0;
        for (const std::int32_t t : star_) before += shape(t, false).skewness > 0.8 ? 1 : 0;
        star_cost(v, candidates[static_cast<std::size_t>(best)], Objective::Skewness);
        const auto after = static_cast<std::size_t>(std::count_if(
            trial_skewness_.begin(), trial_skewness_.end(), [](double x) { return x > 0.8; }));
        if (after > before) return false;
    }
    topo_.set_point(v, candidates[static_cast<std::size_t>(best)]);
    edited(star_);
    moved_node(v);
    return true;
}

}  // namespace frontmesh::volume
