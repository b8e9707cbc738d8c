#include "volume/refine_ops.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/quality.h"

namespace frontmesh::volume {

namespace {

using V3 = Eigen::Vector3d;
constexpr double kInf = std::numeric_limits<double>::infinity();
// insert_node's rescue of the slivers the other operations leave (see there).
constexpr double kRescueDihedralDeg = 10.0;  // slivers under this smallest angle
constexpr double kRescueTargetDeg = 15.0;    // beyond it, the usual order decides
constexpr double kRescueMinGainDeg = 2.0;    // a gain below the target is kept from this
constexpr std::size_t kRescueExtraCaps = 8;  // more tets above skewness 0.8, at most
constexpr double kRegularDihedralDeg = 70.528779365509308;  // arccos(1/3)

/// Tets with skewness above 0.8 (the acceptance figure) among `tets` / the tets with ids `ids`.
std::size_t over_08(const TetTopology& topo, std::span<const Tet> tets) {
    std::size_t n = 0;
    for (const Tet& t : tets)
        if (tet_shape(topo.xyz(t[0]), topo.xyz(t[1]), topo.xyz(t[2]), topo.xyz(t[3]), false).skewness > 0.8) ++n;
    return n;
}
std::size_t over_08(const TetTopology& topo, std::span<const std::int32_t> ids) {
    std::size_t n = 0;
    for (const std::int32_t id : ids) {
        const Tet& t = topo.tet(id);
        if (tet_shape(topo.xyz(t[0]), topo.xyz(t[1]), topo.xyz(t[2]), topo.xyz(t[3]), false).skewness > 0.8) ++n;
    }
    return n;
}

bool tet_positive(const TetTopology& topo, const Tet& t) {
    return positive_tet(topo.xyz(t[0]), topo.xyz(t[1]), topo.xyz(t[2]), topo.xyz(t[3]));
}

}  // namespace

TetShape tet_shape(const double* pa, const double* pb, const double* pc, const double* pd, bool dihedral) {
    const V3 a = Eigen::Map<const V3>(pa), u = Eigen::Map<const V3>(pb) - a,
             v = Eigen::Map<const V3>(pc) - a, w = Eigen::Map<const V3>(pd) - a;
    const V3 vw = v.cross(w), wu = w.cross(u), uv = u.cross(v);
    const double det = u.dot(vw);  // 6 V, > 0 for a VTK-positive tet
    const double uu = u.squaredNorm(), vv = v.squaredNorm(), ww = w.squaredNorm();
    const double l2 = uu + vv + ww + (v - u).squaredNorm() + (w - u).squaredNorm() + (w - v).squaredNorm();
    const double l_rms = std::sqrt(l2 / 6.0);
    TetShape shape;
    // Eq. 1 through the circumradius is ill-conditioned for nearly flat tets (four almost
    // co-circular nodes can give any radius, even "equilateral"): below a normalised volume of
    // 1e-6 (6 sqrt(2) V / l_rms^3, 1 for the regular tet) the tet counts as degenerate.
    if (!(std::sqrt(2.0) * std::abs(det) >= 1e-6 * l_rms * l_rms * l_rms)) return shape;
    // Eq. 1: circumcentre offset from a = (|u|^2 v x w + |v|^2 w x u + |w|^2 u x v) / (2 det).
    const double R = (uu * vw + vv * wu + ww * uv).norm() / (2.0 * std::abs(det));
    const double volume = std::abs(det) / 6.0;
    const double v_opt = 8.0 * std::sqrt(3.0) / 27.0 * R * R * R;
    shape.skewness = std::clamp((v_opt - volume) / v_opt, 0.0, 1.0);
    if (!dihedral) return shape;
    // Outward face normals (for positive det): face opposite a is (b, c, d), etc. The interior
    // dihedral angle between faces i and j is pi - acos(n_i . n_j): the smallest angle belongs
    // to the smallest dot product, so one acos suffices.
    const V3 bc = v - u, bd = w - u;
    std::array<V3, 4> n{bc.cross(bd), -vw, -wu, -uv};  // opposite a, b, c, d
    if (det < 0.0)
        for (V3& x : n) x = -x;
    double smallest = 1.0;
    for (V3& x : n) {
        const double length = x.norm();
        if (length == 0.0) {
            shape.min_dihedral_deg = 0.0;
            return shape;
        }
        x /= length;
    }
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) smallest = std::min(smallest, n[static_cast<std::size_t>(i)].dot(n[static_cast<std::size_t>(j)]));
    shape.min_dihedral_deg = (std::numbers::pi - std::acos(std::clamp(smallest, -1.0, 1.0))) * 180.0 / std::numbers::pi;
    return shape;
}

double tet_cost(const TetTopology& topo, const Tet& t, Objective objective) {
    const TetShape s = tet_shape(topo.xyz(t[0]), topo.xyz(t[1]), topo.xyz(t[2]), topo.xyz(t[3]),
                                 objective == Objective::Combined);
    if (objective == Objective::Skewness) return s.skewness;
    // A tet on a poor input triangle keeps a skewness above 0.8 whatever is done around it (Eq. 1
    // follows the triangle's circumradius); judged by its skewness it would block every change
    // near it, so its dihedral angles alone count.
    if (topo.has_poor_face(t)) return 1.0 - s.min_dihedral_deg / kRegularDihedralDeg;
    return std::max(s.skewness, 1.0 - s.min_dihedral_deg / kRegularDihedralDeg);
}

void RefineOps::prepare_cache() const {
    if (cache_stamp_ != topo_.stamp()) {  // edited elsewhere (or the first call): start afresh
        cache_.assign(static_cast<std::size_t>(topo_.tet_capacity()), CachedShape{});
        cache_stamp_ = topo_.stamp();
        bad_valid_ = false;
    } else if (cache_.size() < static_cast<std::size_t>(topo_.tet_capacity())) {
        cache_.resize(static_cast<std::size_t>(topo_.tet_capacity()));
    }
}

void RefineOps::touch(std::span<const std::int32_t> tets) {
    if (touched_mark_.size() < static_cast<std::size_t>(topo_.tet_capacity()))
        touched_mark_.resize(static_cast<std::size_t>(topo_.tet_capacity()), 0);
    for (const std::int32_t t : tets)
        if (!touched_mark_[static_cast<std::size_t>(t)]) {
            touched_mark_[static_cast<std::size_t>(t)] = 1;
            touched_.push_back(t);
        }
}

void RefineOps::edited(std::span<const std::int32_t> tets) {
    if (cache_.size() < static_cast<std::size_t>(topo_.tet_capacity()))
        cache_.resize(static_cast<std::size_t>(topo_.tet_capacity()));
    // Every change made here keeps tets strictly positive (checked exactly before it is made).
    for (const std::int32_t t : tets)
        cache_[static_cast<std::size_t>(t)].known = kOrientation | kPositive;
    cache_stamp_ = topo_.stamp();
    touch(tets);
}

TetShape RefineOps::shape(std::int32_t t, bool dihedral) const {
    if (cache_stamp_ != topo_.stamp() || static_cast<std::size_t>(t) >= cache_.size())
        prepare_cache();
    CachedShape& c = cache_[static_cast<std::size_t>(t)];
    const std::uint8_t need = dihedral ? kSkewness | kDihedral : kSkewness;
    if ((c.known & need) != need) {
        // tet_shape computes the skewness identically with or without the dihedral angle.
        const Tet& tt = topo_.tet(t);
        const TetShape s = tet_shape(topo_.xyz(tt[0]), topo_.xyz(tt[1]), topo_.xyz(tt[2]),
                                     topo_.xyz(tt[3]), dihedral);
        c.skewness = s.skewness;
        c.known |= kSkewness;
        if (dihedral) {
            c.min_dihedral_deg = s.min_dihedral_deg;
            c.known |= kDihedral;
        }
        return s;
    }
    return {c.skewness, dihedral ? c.min_dihedral_deg : 0.0};
}

bool RefineOps::is_positive(std::int32_t t) const {
    if (cache_stamp_ != topo_.stamp() || static_cast<std::size_t>(t) >= cache_.size())
        prepare_cache();
    CachedShape& c = cache_[static_cast<std::size_t>(t)];
    if (!(c.known & kOrientation))
        c.known |= kOrientation | (tet_positive(topo_, topo_.tet(t)) ? kPositive : 0);
    return (c.known & kPositive) != 0;
}

double RefineOps::cost(std::int32_t t, Objective objective) const {
    const TetShape s = shape(t, objective == Objective::Combined);
    if (objective == Objective::Skewness) return s.skewness;
    // As tet_cost.
    if (topo_.has_poor_face(topo_.tet(t))) return 1.0 - s.min_dihedral_deg / kRegularDihedralDeg;
    return std::max(s.skewness, 1.0 - s.min_dihedral_deg / kRegularDihedralDeg);
}

/// §3.3.1: unconditional removal of interior nodes with small stars.
void RefineOps::remove_nodes() {
    for (int sweep = 0; sweep < 2; ++sweep) {
        std::size_t removed = 0;
        for (std::int32_t v = topo_.mesh().surface_vertices; v < topo_.node_capacity(); ++v) {
            if (topo_.node_tet(v) < 0) continue;
            if (remove_node(v, params_.node_removal_max_tets, Objective::Skewness, false))
                ++removed;
        }
        counts.nodes_removed += removed;
        if (removed == 0) break;
    }
}

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

void RefineOps::changed_tets(std::span<const std::int32_t> tets) {
    const auto n = static_cast<std::size_t>(topo_.tet_capacity());
    if (settled_.size() < n) settled_.resize(n, 0);
    if (node_settled_.size() < static_cast<std::size_t>(topo_.node_capacity()))
        node_settled_.resize(static_cast<std::size_t>(topo_.node_capacity()), 0);
    for (const std::int32_t t : tets) {
        settled_[static_cast<std::size_t>(t)] = 0;
        for (int i = 0; i < 4; ++i) {
            const std::int32_t u = topo_.neighbor(t, i);
            if (u >= 0) settled_[static_cast<std::size_t>(u)] = 0;
        }
        if (!topo_.alive(t)) continue;
        for (const std::int32_t v : topo_.tet(t)) node_settled_[static_cast<std::size_t>(v)] = 0;
    }
}

void RefineOps::moved_node(std::int32_t v) {
    // As changed_tets(star_), cheaper: the faces of a star tet through v lead to star tets, the
    // face opposite v leads outside; the star's nodes are v and link_.
    if (node_settled_.size() < static_cast<std::size_t>(topo_.node_capacity()))
        node_settled_.resize(static_cast<std::size_t>(topo_.node_capacity()), 0);
    if (settled_.size() < static_cast<std::size_t>(topo_.tet_capacity()))
        settled_.resize(static_cast<std::size_t>(topo_.tet_capacity()), 0);
    for (const std::int32_t t : star_) {
        settled_[static_cast<std::size_t>(t)] = 0;
        const std::int32_t u = topo_.neighbor(t, local_index(topo_.tet(t), v));
        if (u >= 0) settled_[static_cast<std::size_t>(u)] = 0;
    }
    node_settled_[static_cast<std::size_t>(v)] = 0;
    for (const std::int32_t w : link_) node_settled_[static_cast<std::size_t>(w)] = 0;
}

void RefineOps::apply(std::span<const std::int32_t> old_tets, std::span<const Tet> new_tets, core::Label region) {
    prepare_cache();
    topo_.replace(old_tets, new_tets, region, &new_ids_);
    edited(new_ids_);
    changed_tets(new_ids_);
}

/// §3.3.3: flips around tets with skewness > flip_skewness, worst first.
void RefineOps::flips() {
    for (int sweep = 0; sweep < params_.flip_sweeps; ++sweep) {
        const auto candidates = bad_tets(Objective::Skewness, params_.flip_skewness);
        settled_.resize(static_cast<std::size_t>(topo_.tet_capacity()), 0);
        std::size_t changed = 0;
        for (const std::int32_t t : candidates) {
            // Tets tried without success are skipped until they or a neighbour change.
            if (!topo_.alive(t) || settled_[static_cast<std::size_t>(t)]) continue;
            if (cost(t, Objective::Skewness) <= params_.flip_skewness) continue;
            if (improve_by_flips(t, Objective::Skewness, params_.flip_delaunay_test)) ++changed;
            else settled_[static_cast<std::size_t>(t)] = 1;
        }
        if (changed == 0) break;
    }
}

/// Beyond the paper: slivers (small dihedral) and remaining caps, worst first: flips with the
/// combined objective, then moves of their interior nodes, then conditional node removal.
void RefineOps::slivers() {
    const double threshold = 1.0 - params_.sliver_dihedral_deg / kRegularDihedralDeg;
    const double target = std::min(threshold, 0.8);
    settled_.assign(static_cast<std::size_t>(topo_.tet_capacity()), 0);  // a new objective
    for (int sweep = 0; sweep < params_.sliver_sweeps; ++sweep) {
        const auto candidates = bad_tets(Objective::Combined, target);
        settled_.resize(static_cast<std::size_t>(topo_.tet_capacity()), 0);
        std::size_t changed = 0;
        for (const std::int32_t t : candidates) {
            if (!topo_.alive(t) || settled_[static_cast<std::size_t>(t)]) continue;
            if (cost(t, Objective::Combined) <= target) continue;
            if (improve_by_flips(t, Objective::Combined, false)) {
                ++counts.sliver_flips;
                ++changed;
                continue;
            }
            const Tet tt = topo_.tet(t);
            bool done = false;
            for (int i = 0; i < 4 && !done; ++i) {
                const std::int32_t v = tt[static_cast<std::size_t>(i)];
                if (topo_.is_surface_node(v)) continue;
                if (move_node(v, tt, i)) {
                    ++counts.sliver_moves;
                    done = true;
                }
            }
            for (int i = 0; i < 4 && !done; ++i) {
                const std::int32_t v = tt[static_cast<std::size_t>(i)];
                if (topo_.is_surface_node(v)) continue;
                if (remove_node(v, 24, Objective::Combined, true)) {
                    ++counts.sliver_removals;
                    done = true;
                }
            }
            if (!done && insert_node(t, Objective::Combined)) {
                ++counts.sliver_insertions;
                done = true;
            }
            if (done) ++changed;
            else settled_[static_cast<std::size_t>(t)] = 1;
        }
        if (changed == 0) break;
    }
}

std::vector<std::int32_t> RefineOps::bad_tets(Objective objective, double threshold) const {
    prepare_cache();
    const auto worse = [](const std::pair<double, std::int32_t>& x,
                          const std::pair<double, std::int32_t>& y) {
        return x.first != y.first ? x.first > y.first : x.second < y.second;
    };
    if (touched_mark_.size() < static_cast<std::size_t>(topo_.tet_capacity()))
        touched_mark_.resize(static_cast<std::size_t>(topo_.tet_capacity()), 0);
    if (bad_valid_ && bad_objective_ == objective && bad_threshold_ == threshold) {
        // Only the tets changed since the last list have a new cost: drop them from it, then
        // merge them back in with their new costs (the same list as a full scan, cheaper).
        std::vector<std::pair<double, std::int32_t>> kept, fresh;
        kept.reserve(bad_list_.size());
        for (const auto& b : bad_list_)
            if (topo_.alive(b.second) && !touched_mark_[static_cast<std::size_t>(b.second)])
                kept.push_back(b);
        for (const std::int32_t t : touched_) {
            touched_mark_[static_cast<std::size_t>(t)] = 0;
            if (!topo_.alive(t)) continue;
            const double c = cost(t, objective);
            if (c > threshold) fresh.emplace_back(c, t);
        }
        touched_.clear();
        std::sort(fresh.begin(), fresh.end(), worse);
        bad_list_.resize(kept.size() + fresh.size());
        std::merge(kept.begin(), kept.end(), fresh.begin(), fresh.end(), bad_list_.begin(), worse);
    } else {
        // Costs in parallel (each tet independent; each cache entry written by one task),
        // collected per block and joined in block order: deterministic.
        constexpr std::int32_t kBlock = 8192;
        const std::int32_t n = topo_.tet_capacity();
        std::vector<std::vector<std::pair<double, std::int32_t>>> part(
            static_cast<std::size_t>((n + kBlock - 1) / kBlock));
        tbb::parallel_for(
            std::int32_t{0}, static_cast<std::int32_t>(part.size()), [&](std::int32_t b) {
                auto& out = part[static_cast<std::size_t>(b)];
                for (std::int32_t t = b * kBlock; t < std::min(n, (b + 1) * kBlock); ++t) {
                    if (!topo_.alive(t)) continue;
                    const double c = cost(t, objective);
                    if (c > threshold) out.emplace_back(c, t);
                }
            });
        bad_list_.clear();
        for (const auto& p : part) bad_list_.insert(bad_list_.end(), p.begin(), p.end());
        std::sort(bad_list_.begin(), bad_list_.end(), worse);
        for (const std::int32_t t : touched_) touched_mark_[static_cast<std::size_t>(t)] = 0;
        touched_.clear();
        bad_valid_ = true;
        bad_objective_ = objective;
        bad_threshold_ = threshold;
    }
    std::vector<std::int32_t> out;
    out.reserve(bad_list_.size());
    for (const auto& b : bad_list_) out.push_back(b.second);
    return out;
}

double RefineOps::max_cost(std::span<const std::int32_t> tets, Objective objective) const {
    double worst = 0.0;
    for (const std::int32_t t : tets) worst = std::max(worst, cost(t, objective));
    return worst;
}

/// Removes interior node v when its star has at most `max_tets` tets and the hole can be
/// filled by a fan from one of its link nodes (all new tets positive, exact). The fan with
/// the smallest largest cost is used; with `conditional` only when that beats the star.
bool RefineOps::remove_node(std::int32_t v, int max_tets, Objective objective, bool conditional) {
    if (!topo_.star(v, star_, static_cast<std::size_t>(max_tets))) return false;
    link_.clear();
    for (const std::int32_t t : star_)
        for (const std::int32_t w : topo_.tet(t))
            if (w != v && std::find(link_.begin(), link_.end(), w) == link_.end()) link_.push_back(w);
    std::sort(link_.begin(), link_.end());
    double best = conditional ? max_cost(star_, objective) : kInf;
    bool found = false;
    for (const std::int32_t w : link_) {
        candidate_.clear();
        bool valid = true;
        double worst = 0.0;
        for (const std::int32_t t : star_) {
            Tet nt = topo_.tet(t);
            if (local_index(nt, w) >= 0) continue;
            nt[static_cast<std::size_t>(local_index(nt, v))] = w;
            if (!tet_positive(topo_, nt)) {
                valid = false;
                break;
            }
            worst = std::max(worst, tet_cost(topo_, nt, objective));
            candidate_.push_back(nt);
        }
        if (!valid || worst >= best) continue;
        best = worst;
        best_ = candidate_;
        found = true;
    }
    if (!found) return false;
    // The sliver objective trades skewness for dihedral angle: never at the price of more tets
    // above skewness 0.8.
    if (objective == Objective::Combined && over_08(topo_, best_) > over_08(topo_, star_)) return false;
    apply(star_, best_, topo_.region(star_[0]));
    return true;
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
        V3 direction = axis_length > 1e-9 * (length + 1e-300) ? V3(axis / axis_length) : V3(jv / length);
        if (direction.dot(jv) < 0.0) direction = -direction;
        sum += pj + length * direction;  // N_j rotated onto the cone axis, |N_j v| kept
    }
    return link_.empty() ? pv : V3(sum / static_cast<double>(link_.size()));
}

/// Largest cost and the cost sum of the star of v with v at p; +inf when a tet would not be
/// strictly positive (exact).
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
        if (objective == Objective::Combined) {
            const double dihedral_cost = 1.0 - s.min_dihedral_deg / kRegularDihedralDeg;
            c = topo_.has_poor_face(tt) ? dihedral_cost : std::max(s.skewness, dihedral_cost);
        }
        if (c > bound || !positive_tet(x[0], x[1], x[2], x[3])) {
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
    std::uint64_t state = 0x9E3779B97F4A7C15ull ^ static_cast<std::uint64_t>(v) * 0xBF58476D1CE4E5B9ull;
    auto next = [&]() {
        state ^= state >> 33;
        state *= 0xff51afd7ed558ccdull;
        state ^= state >> 33;
        return static_cast<double>(state >> 11) / 9007199254740992.0 * 2.0 - 1.0;
    };
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

/// Edge suppression: removes edge (a, b) (around tet t) and fills its ring polygon with the
/// triangulation minimising the largest cost (dynamic programming over the polygon); kept only
/// when that beats the ring's current largest cost. 3 -> 2, 4 -> 4, n -> 2n - 4.
bool RefineOps::remove_edge(std::int32_t a, std::int32_t b, std::int32_t t, Objective objective) {
    ++counts.edge_rings;
    if (!topo_.edge_ring(a, b, t, ring_tets_, ring_)) return false;
    const int n = static_cast<int>(ring_.size());
    if (n < 3 || n > params_.flip_max_ring) return false;
    const double old_worst = unconditional_ ? kInf : max_cost(ring_tets_, objective);
    constexpr int kMax = 10;
    std::array<std::array<double, kMax>, kMax> best{};
    std::array<std::array<int, kMax>, kMax> arg{};
    auto new_tets = [&](int i, int k, int j) {
        const std::int32_t ri = ring_[static_cast<std::size_t>(i)];
        const std::int32_t rk = ring_[static_cast<std::size_t>(k)];
        const std::int32_t rj = ring_[static_cast<std::size_t>(j)];
        return std::array<Tet, 2>{Tet{ri, rk, rj, b}, Tet{ri, rj, rk, a}};
    };
    for (int i = 0; i + 1 < n; ++i) best[static_cast<std::size_t>(i)][static_cast<std::size_t>(i + 1)] = 0.0;
    for (int len = 2; len < n; ++len) {
        for (int i = 0; i + len < n; ++i) {
            const int j = i + len;
            double value = kInf;
            int choice = -1;
            for (int k = i + 1; k < j; ++k) {
                const double sub = std::max(best[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)],
                                            best[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)]);
                if (sub >= value || sub >= old_worst) continue;
                const auto pair = new_tets(i, k, j);
                // A pair costing `bound` or more is never chosen, or leaves a value no
                // accepted triangulation uses (every larger interval skips it, as sub >=
                // old_worst): stop evaluating it there.
                const double bound = std::min(value, old_worst);
                double c = sub;
                for (const Tet& nt : pair) {
                    if (!tet_positive(topo_, nt)) {
                        c = kInf;
                        break;
                    }
                    const double x = tet_cost(topo_, nt, objective);
                    if (x >= bound) {
                        c = kInf;
                        break;
                    }
                    c = std::max(c, x);
                }
                if (c < value) {
                    value = c;
                    choice = k;
                }
            }
            best[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = value;
            arg[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = choice;
        }
    }
    if (!(best[0][static_cast<std::size_t>(n - 1)] < old_worst)) return false;
    candidate_.clear();
    std::vector<std::pair<int, int>> stack{{0, n - 1}};
    while (!stack.empty()) {
        const auto [i, j] = stack.back();
        stack.pop_back();
        if (j - i < 2) continue;
        const int k = arg[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
        const auto pair = new_tets(i, k, j);
        candidate_.push_back(pair[0]);
        candidate_.push_back(pair[1]);
        stack.emplace_back(i, k);
        stack.emplace_back(k, j);
    }
    const core::Label r = topo_.region(ring_tets_[0]);
    if (objective == Objective::Combined && over_08(topo_, candidate_) > over_08(topo_, ring_tets_)) return false;
    apply(ring_tets_, candidate_, r);
    if (n == 3) ++counts.flips_3_2;
    else if (n == 4) ++counts.flips_4_4;
    else ++counts.flips_n_m;
    return true;
}

namespace {

/// True when the triangles (each seen from inside) bound a topological sphere: every edge in
/// exactly two of them, every vertex's triangles one fan, V - E + F = 2.
bool is_sphere(const std::vector<std::array<std::int32_t, 3>>& faces) {
    std::vector<std::pair<std::int32_t, std::int32_t>> edges;
    std::vector<std::int32_t> vertices;
    for (const auto& f : faces)
        for (int i = 0; i < 3; ++i) {
            const std::int32_t a = f[static_cast<std::size_t>(i)],
                               b = f[static_cast<std::size_t>((i + 1) % 3)];
            edges.emplace_back(std::min(a, b), std::max(a, b));
            vertices.push_back(a);
        }
    std::sort(edges.begin(), edges.end());
    for (std::size_t i = 0; i < edges.size(); i += 2)
        if (i + 1 >= edges.size() || edges[i] != edges[i + 1] ||
            (i + 2 < edges.size() && edges[i + 2] == edges[i]))
            return false;
    std::sort(vertices.begin(), vertices.end());
    vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
    const long euler = static_cast<long>(vertices.size()) - static_cast<long>(edges.size() / 2) +
                       static_cast<long>(faces.size());
    if (euler != 2) return false;
    // One fan per vertex: walk its link (edge b -> c of each triangle (v, b, c)) once around.
    std::vector<std::pair<std::int32_t, std::int32_t>> link;
    for (const std::int32_t v : vertices) {
        link.clear();
        for (const auto& f : faces) {
            const int i = static_cast<int>(std::find(f.begin(), f.end(), v) - f.begin());
            if (i < 3)
                link.emplace_back(f[static_cast<std::size_t>((i + 1) % 3)],
                                  f[static_cast<std::size_t>((i + 2) % 3)]);
        }
        std::size_t steps = 1;
        std::int32_t at = link[0].second;
        while (at != link[0].first && steps <= link.size()) {
            const auto next = std::find_if(link.begin(), link.end(),
                                           [&](const auto& e) { return e.first == at; });
            if (next == link.end()) return false;
            at = next->second;
            ++steps;
        }
        if (steps != link.size()) return false;
    }
    return true;
}

}  // namespace

bool RefineOps::insert_node(std::int32_t t, Objective objective) {
    constexpr std::size_t kMaxCavity = 40;
    const core::Label region = topo_.region(t);
    std::vector<std::array<std::int32_t, 3>> boundary;
    std::vector<V3> candidates;
    // The chosen cavity, boundary and node among the variants.
    std::vector<std::int32_t> chosen_cavity;
    std::vector<std::array<std::int32_t, 3>> chosen_boundary;
    V3 chosen_p = V3::Zero();
    double chosen_cost = kInf;
    double chosen_dihedral = 0.0;
    const Tet t_nodes = topo_.tet(t);
    // Rescue: a sliver under kRescueDihedralDeg that no flip, move or removal improved. Then the
    // smallest dihedral angle comes first and the count of tets above skewness 0.8 may grow
    // (by at most kRescueExtraCaps): on a thin or convex stretch of the boundary every split of
    // the sliver leaves a few long tets (skewness > 0.8 with dihedral angles of 20 degrees and
    // more, e.g. AAL region 62), which are far better elements and which the later sweeps can
    // still improve, the new node being free to move.
    const bool rescue =
        tet_shape(topo_.xyz(t_nodes[0]), topo_.xyz(t_nodes[1]), topo_.xyz(t_nodes[2]),
                  topo_.xyz(t_nodes[3]), true)
            .min_dihedral_deg < kRescueDihedralDeg;
    for (int variant = 0; variant < 8; ++variant) {
        if (variant < 6) {
            // The ring of an edge of t not on a wall: the node splits the edge, then moves.
            static constexpr int kEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
            if (!topo_.edge_ring(t_nodes[static_cast<std::size_t>(kEdge[variant][0])],
                                 t_nodes[static_cast<std::size_t>(kEdge[variant][1])], t,
                                 ring_tets_, ring_))
                continue;
            cavity_ = ring_tets_;
        } else {
            // t, then the tets across the non-wall faces of the tets already in the cavity.
            cavity_.assign(1, t);
            for (int r = 0; r < variant - 5; ++r) {
                const std::size_t n = cavity_.size();
                for (std::size_t k = 0; k < n; ++k)
                    for (int i = 0; i < 4; ++i) {
                        const std::int32_t u = topo_.neighbor(cavity_[k], i);
                        if (u >= 0 && std::find(cavity_.begin(), cavity_.end(), u) == cavity_.end())
                            cavity_.push_back(u);
                    }
            }
        }
        if (cavity_.size() > kMaxCavity) continue;
        boundary.clear();
        for (const std::int32_t c : cavity_)
            for (int i = 0; i < 4; ++i) {
                const std::int32_t u = topo_.neighbor(c, i);
                if (u >= 0 && std::find(cavity_.begin(), cavity_.end(), u) != cavity_.end())
                    continue;
                const auto f =
                    tet_face(topo_.tet(c), i);  // outward; the new node sees it from inside
                boundary.push_back({f[0], f[2], f[1]});
            }
        if (!is_sphere(boundary)) continue;
        // What the node is placed for: fewest tets above skewness 0.8, then the smallest largest
        // cost (on a poor input triangle the dihedral term alone, as tet_cost), then the largest
        // smallest dihedral angle.
        struct Score {
            std::size_t over = 0;
            double min_dihedral = 180.0, max_cost = 0.0;
            bool valid = false;
        };
        Score old;
        old.valid = true;
        for (const std::int32_t c : cavity_) {
            const Tet& q = topo_.tet(c);
            const TetShape shape =
                tet_shape(topo_.xyz(q[0]), topo_.xyz(q[1]), topo_.xyz(q[2]), topo_.xyz(q[3]), true);
            old.over += shape.skewness > 0.8 ? 1 : 0;
            old.min_dihedral = std::min(old.min_dihedral, shape.min_dihedral_deg);
        }
        old.max_cost = max_cost(cavity_, objective);
        auto score = [&](const V3& p) {
            Score s;
            for (const auto& f : boundary) {
                const double *a = topo_.xyz(f[0]), *b = topo_.xyz(f[1]), *c = topo_.xyz(f[2]);
                if (!positive_tet(a, b, c, p.data())) return s;
                const TetShape shape = tet_shape(a, b, c, p.data(), true);
                s.over += shape.skewness > 0.8 ? 1 : 0;
                if (s.over > old.over + (rescue ? kRescueExtraCaps : 0))
                    return s;  // never kept: not worth finishing
                s.min_dihedral = std::min(s.min_dihedral, shape.min_dihedral_deg);
                const double dihedral_cost = 1.0 - shape.min_dihedral_deg / kRegularDihedralDeg;
                s.max_cost = std::max(s.max_cost, objective == Objective::Skewness ? shape.skewness
                                                  : topo_.is_poor_face(f[0], f[1], f[2])
                                                      ? dihedral_cost
                                                      : std::max(shape.skewness, dihedral_cost));
            }
            s.valid = true;
            return s;
        };
        auto better = [&](const Score& x, const Score& y) {
            if (x.valid != y.valid) return x.valid;
            if (rescue) {  // the smallest angle first, up to the rescue target
                const double dx = std::min(x.min_dihedral, kRescueTargetDeg);
                const double dy = std::min(y.min_dihedral, kRescueTargetDeg);
                if (dx != dy) return dx > dy;
            }
            if (x.over != y.over) return x.over < y.over;
            if (x.max_cost != y.max_cost) return x.max_cost < y.max_cost;
            return x.min_dihedral > y.min_dihedral;
        };
        // Candidates: the ideal apex over each boundary face, on its inner side (height
        // sqrt(2/3) of its mean edge), the centroids of t and of the boundary nodes.
        candidates.clear();
        V3 centroid_t = V3::Zero(), centroid_b = V3::Zero();
        for (const std::int32_t v : topo_.tet(t)) centroid_t += topo_.point(v) / 4.0;
        double h = 0.0;
        for (const auto& f : boundary) {
            const V3 a = topo_.point(f[0]), b = topo_.point(f[1]), c = topo_.point(f[2]);
            const V3 n = (b - a).cross(c - a);  // towards the inside: (a, b, c, p) positive
            const double edge = ((b - a).norm() + (c - b).norm() + (a - c).norm()) / 3.0;
            h += edge;
            centroid_b += a + b + c;
            if (n.norm() > 0.0)
                candidates.push_back((a + b + c) / 3.0 +
                                     std::sqrt(2.0 / 3.0) * edge * n.normalized());
        }
        h /= static_cast<double>(boundary.size());
        centroid_b /= static_cast<double>(3 * boundary.size());
        candidates.push_back(centroid_t);
        candidates.push_back(centroid_b);
        candidates.push_back(0.5 * (centroid_t + centroid_b));
        if (rescue) {
            // The deepest point of the cavity's kernel (largest smallest height over the
            // boundary face planes), by subgradient steps along the normal of the lowest face:
            // the kernel of a thin cavity can miss every point above.
            std::vector<V3> unit(boundary.size()), on_plane(boundary.size());
            for (std::size_t i = 0; i < boundary.size(); ++i) {
                const V3 a = topo_.point(boundary[i][0]), b = topo_.point(boundary[i][1]),
                         c = topo_.point(boundary[i][2]);
                const V3 n = (b - a).cross(c - a);
                unit[i] = n.norm() > 0.0 ? V3(n.normalized()) : V3::Zero();
                on_plane[i] = a;
            }
            auto lowest = [&](const V3& p, std::size_t& which) {
                double low = kInf;
                for (std::size_t i = 0; i < boundary.size(); ++i) {
                    const double d = unit[i].dot(p - on_plane[i]);
                    if (d < low) low = d, which = i;
                }
                return low;
            };
            V3 p = centroid_b, deepest = centroid_b;
            std::size_t which = 0;
            double deepest_low = lowest(p, which);
            double step = 0.2 * h;
            for (int it = 0; it < 200; ++it, step *= 0.97) {
                p += step * unit[which];
                const double low = lowest(p, which);
                if (low > deepest_low) deepest_low = low, deepest = p;
            }
            candidates.push_back(deepest);
            candidates.push_back(0.5 * (deepest + centroid_b));
            candidates.push_back(0.5 * (deepest + centroid_t));
        }
        V3 best_p = centroid_b;
        Score best;
        for (const V3& p : candidates) {
            const Score s = score(p);
            if (better(s, best)) best = s, best_p = p;
        }
        // A small deterministic search around the best (fixed offsets from the tet id).
        std::uint64_t state =
            0x9E3779B97F4A7C15ull ^ static_cast<std::uint64_t>(t) * 0xBF58476D1CE4E5B9ull;
        auto next = [&]() {
            state ^= state >> 33;
            state *= 0xff51afd7ed558ccdull;
            state ^= state >> 33;
            return static_cast<double>(state >> 11) / 9007199254740992.0 * 2.0 - 1.0;
        };
        for (const double step : {0.3, 0.15, 0.07, 0.03})
            for (int k = 0; k < 12; ++k) {
                const V3 d(next(), next(), next());
                if (d.norm() < 1e-6) continue;
                const V3 p = best_p + step * h * d.normalized();
                const Score s = score(p);
                if (better(s, best)) best = s, best_p = p;
            }
        // Kept when valid, with no more tets above skewness 0.8, and either the smallest
        // dihedral angle larger with the largest cost not larger, or the largest cost smaller
        // with the smallest dihedral angle not smaller (unless it stays above the sliver
        // threshold): near 1 the skewness saturates, so the cost alone could trade a 1 deg
        // sliver for a 0.1 deg one.
        if (rescue) {
            // Kept when the smallest angle grows to the target, or by kRescueMinGainDeg
            if (!best.valid || !(best.min_dihedral > old.min_dihedral &&
                                 (best.min_dihedral >= kRescueTargetDeg ||
                                  best.min_dihedral >= old.min_dihedral + kRescueMinGainDeg)))
                continue;
            if (best.min_dihedral > chosen_dihedral ||
                (best.min_dihedral == chosen_dihedral && best.max_cost < chosen_cost)) {
                chosen_dihedral = best.min_dihedral;
                chosen_cost = best.max_cost;
                chosen_cavity = cavity_;
                chosen_boundary = boundary;
                chosen_p = best_p;
            }
            continue;
        }
        const bool dihedral_gain =
            best.min_dihedral > old.min_dihedral && best.max_cost <= old.max_cost;
        const bool cost_gain =
            best.max_cost < old.max_cost &&
            best.min_dihedral >= std::min(old.min_dihedral, params_.sliver_dihedral_deg);
        if (!best.valid || best.over > old.over || !(dihedral_gain || cost_gain)) continue;
        if (best.max_cost < chosen_cost) {
            chosen_cost = best.max_cost;
            chosen_cavity = cavity_;
            chosen_boundary = boundary;
            chosen_p = best_p;
        }
    }
    if (chosen_cavity.empty()) return false;
    std::int32_t level = 0;
    if (!topo_.mesh().level.empty())
        for (const std::int32_t c : chosen_cavity)
            for (const std::int32_t v : topo_.tet(c))
                level = std::max(level, topo_.mesh().level[static_cast<std::size_t>(v)]);
    prepare_cache();
    const std::int32_t v = topo_.add_node(chosen_p, level);
    edited({});  // a new node changes no tet yet
    candidate_.clear();
    for (const auto& f : chosen_boundary) candidate_.push_back({f[0], f[1], f[2], v});
    apply(chosen_cavity, candidate_, region);
    return true;
}

/// 2 -> 3: face i of tet t and the tet across it become three tets around the new edge AB.
bool RefineOps::flip_2_3(std::int32_t t, int i, Objective objective) {
    const std::int32_t u = topo_.neighbor(t, i);
    if (u < 0) return false;
    const Tet tt = topo_.tet(t);
    const auto f = tet_face(tt, i);
    std::int32_t b = -1;
    for (const std::int32_t w : topo_.tet(u))
        if (w != f[0] && w != f[1] && w != f[2]) b = w;
    const double old_worst =
        unconditional_ ? kInf : std::max(cost(t, objective), cost(u, objective));
    candidate_.clear();
    double worst = 0.0;
    for (int k = 0; k < 4; ++k) {
        if (k == i) continue;
        Tet nt = tt;
        nt[static_cast<std::size_t>(k)] = b;  // B takes the place of a node of F
        if (!tet_positive(topo_, nt)) return false;
        worst = std::max(worst, tet_cost(topo_, nt, objective));
        if (worst >= old_worst) return false;
        candidate_.push_back(nt);
    }
    const std::array<std::int32_t, 2> old{t, u};
    if (objective == Objective::Combined && over_08(topo_, candidate_) > over_08(topo_, old)) return false;
    apply(old, candidate_, topo_.region(t));
    ++counts.flips_2_3;
    return true;
}

/// §3.3.3 steps 2-3 for tet t: nodes A by descending area of the opposite face F; edge
/// suppression on the edges of F first, then the 2 -> 3 swap of F. True when t was replaced.
bool RefineOps::improve_by_flips(std::int32_t t, Objective objective, bool delaunay_test) {
    ++counts.flip_attempts;
    const Tet tt = topo_.tet(t);
    // The faces that may be tried: with the Delaunay test, those whose node A lies inside the
    // circumsphere of the tet T2 across them (decided first: usually none, and then the face
    // areas are not needed).
    std::array<bool, 4> open{true, true, true, true};
    if (delaunay_test) {
        bool any = false;
        for (int i = 0; i < 4; ++i) {
            const std::int32_t u = topo_.neighbor(t, i);
            // insphere wants orient3d(p0..p3) > 0, the opposite of our VTK-positive order:
            // swap two nodes.
            const Tet* ut = u >= 0 ? &topo_.tet(u) : nullptr;
            open[static_cast<std::size_t>(i)] =
                ut &&
                core::insphere(topo_.xyz((*ut)[1]), topo_.xyz((*ut)[0]), topo_.xyz((*ut)[2]),
                               topo_.xyz((*ut)[3]), topo_.xyz(tt[static_cast<std::size_t>(i)])) > 0;
            any = any || open[static_cast<std::size_t>(i)];
        }
        if (!any) return false;
    }
    std::array<std::pair<double, int>, 4> order;
    for (int i = 0; i < 4; ++i) {
        const auto f = tet_face(tt, i);
        order[static_cast<std::size_t>(i)] = {
            -core::triangle_area(topo_.point(f[0]), topo_.point(f[1]), topo_.point(f[2])), i};
    }
    std::sort(order.begin(), order.end());
    std::array<std::array<std::int32_t, 2>, 6> tried{};
    int n_tried = 0;
    for (const auto& [negative_area, i] : order) {
        const std::int32_t u = topo_.neighbor(t, i);
        if (!open[static_cast<std::size_t>(i)]) continue;
        const auto f = tet_face(tt, i);
        for (int e = 0; e < 3; ++e) {
            std::array<std::int32_t, 2> edge{f[static_cast<std::size_t>(e)], f[static_cast<std::size_t>((e + 1) % 3)]};
            if (edge[0] > edge[1]) std::swap(edge[0], edge[1]);
            if (std::find(tried.begin(), tried.begin() + n_tried, edge) != tried.begin() + n_tried) continue;
            tried[static_cast<std::size_t>(n_tried++)] = edge;
            if (remove_edge(edge[0], edge[1], t, objective)) return true;
        }
        if (u >= 0 && flip_2_3(t, i, objective)) return true;
    }
    return false;
}

}  // namespace frontmesh::volume
