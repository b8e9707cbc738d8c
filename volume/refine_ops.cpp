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
#include "volume/refine_ops_shared.h"

// §3.3 on a TetTopology: the shapes and costs of tets (Eq. 1, dihedral angles) with their
// cache, the worst tets, applying a change, and §3.3.1 node removal. Smoothing is
// refine_smooth.cpp, flips refine_flips.cpp, the sliver pass refine_slivers.cpp.

namespace frontmesh::volume {

using namespace refine_detail;

TetShape tet_shape(const double* pa, const double* pb, const double* pc, const double* pd,
                   bool dihedral) {
    const V3 a = Eigen::Map<const V3>(pa), u = Eigen::Map<const V3>(pb) - a,
             v = Eigen::Map<const V3>(pc) - a, w = Eigen::Map<const V3>(pd) - a;
    const V3 vw = v.cross(w), wu = w.cross(u), uv = u.cross(v);
    const double det = u.dot(vw);  // 6 V, > 0 for a VTK-positive tet
    const double uu = u.squaredNorm(), vv = v.squaredNorm(), ww = w.squaredNorm();
    const double l2 =
        uu + vv + ww + (v - u).squaredNorm() + (w - u).squaredNorm() + (w - v).squaredNorm();
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
        for (int j = i + 1; j < 4; ++j)
            smallest = std::min(smallest,
                                n[static_cast<std::size_t>(i)].dot(n[static_cast<std::size_t>(j)]));
    shape.min_dihedral_deg =
        (std::numbers::pi - std::acos(std::clamp(smallest, -1.0, 1.0))) * 180.0 / std::numbers::pi;
    return shape;
}

double tet_cost(const TetTopology& topo, const Tet& t, Objective objective) {
    const TetShape s = tet_shape(topo.xyz(t[0]), topo.xyz(t[1]), topo.xyz(t[2]), topo.xyz(t[3]),
                                 objective == Objective::Combined);
    if (objective == Objective::Skewness) return s.skewness;
    // A tet on a poor input triangle keeps a skewness above 0.8 whatever is done around it (Eq. 1
    // follows the triangle's circumradius); judged by its skewness it would block every change
    // near it, so its dihedral angles alone count.
    return combined_cost(s, topo.has_poor_face(t));
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
    return combined_cost(s, topo_.has_poor_face(topo_.tet(t)));  // as tet_cost
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

void RefineOps::apply(std::span<const std::int32_t> old_tets, std::span<const Tet> new_tets,
                      core::Label region) {
    prepare_cache();
    topo_.replace(old_tets, new_tets, region, &new_ids_);
    edited(new_ids_);
    changed_tets(new_ids_);
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
            if (w != v && std::find(link_.begin(), link_.end(), w) == link_.end())
                link_.push_back(w);
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
            if (!tet_positive(topo_, nt) || !is_within_cap(nt)) {
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
    if (objective == Objective::Combined && over_08(topo_, best_) > over_08(topo_, star_))
        return false;
    apply(star_, best_, topo_.region(star_[0]));
    return true;
}

}  // namespace frontmesh::volume
