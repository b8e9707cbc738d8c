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

// §3.3.3 Delaunay refinement by flips: edge suppression (3 -> 2, 4 -> 4, n -> 2n - 4) and
// 2 -> 3 swaps around the worst tets.

namespace frontmesh::volume {

using namespace refine_detail;

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
            if (improve_by_flips(t, Objective::Skewness, params_.flip_delaunay_test))
                ++changed;
            else
                settled_[static_cast<std::size_t>(t)] = 1;
        }
        if (changed == 0) break;
    }
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
    for (int i = 0; i + 1 < n; ++i)
        best[static_cast<std::size_t>(i)][static_cast<std::size_t>(i + 1)] = 0.0;
    for (int len = 2; len < n; ++len) {
        for (int i = 0; i + len < n; ++i) {
            const int j = i + len;
            double value = kInf;
            int choice = -1;
            for (int k = i + 1; k < j; ++k) {
                const double sub =
                    std::max(best[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)],
                             best[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)]);
                if (sub >= value || sub >= old_worst) continue;
                const auto pair = new_tets(i, k, j);
                // A pair costing `bound` or more is never chosen, or leaves a value no
                // accepted triangulation uses (every larger interval skips it, as sub >=
                // old_worst): stop evaluating it there.
                const double bound = std::min(value, old_worst);
                double c = sub;
                for (const Tet& nt : pair) {
                    if (!tet_positive(topo_, nt) || !is_within_cap(nt)) {
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
    if (objective == Objective::Combined && over_08(topo_, candidate_) > over_08(topo_, ring_tets_))
        return false;
    apply(ring_tets_, candidate_, r);
    if (n == 3)
        ++counts.flips_3_2;
    else if (n == 4)
        ++counts.flips_4_4;
    else
        ++counts.flips_n_m;
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
        if (!tet_positive(topo_, nt) || !is_within_cap(nt)) return false;
        worst = std::max(worst, tet_cost(topo_, nt, objective));
        if (worst >= old_worst) return false;
        candidate_.push_back(nt);
    }
    const std::array<std::int32_t, 2> old{t, u};
    if (objective == Objective::Combined && over_08(topo_, candidate_) > over_08(topo_, old))
        return false;
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
            std::array<std::int32_t, 2> edge{f[static_cast<std::size_t>(e)],
                                             f[static_cast<std::size_t>((e + 1) % 3)]};
            if (edge[0] > edge[1]) std::swap(edge[0], edge[1]);
            if (std::find(tried.begin(), tried.begin() + n_tried, edge) != tried.begin() + n_tried)
                continue;
            tried[static_cast<std::size_t>(n_tried++)] = edge;
            if (remove_edge(edge[0], edge[1], t, objective)) return true;
        }
        if (u >= 0 && flip_2_3(t, i, objective)) return true;
    }
    return false;
}

}  // namespace frontmesh::volume
