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

// Beyond the paper: the sliver pass (flips, moves and removals with the combined objective)
// and its last resort, a new interior node in a cavity around the sliver.

namespace frontmesh::volume {

using namespace refine_detail;

namespace {

// insert_node's rescue of the slivers the other operations leave (see there).
constexpr double kRescueDihedralDeg = 10.0;  // slivers under this smallest angle
constexpr double kRescueTargetDeg = 15.0;    // beyond it, the usual order decides
constexpr double kRescueMinGainDeg = 2.0;    // a gain below the target is kept from this
constexpr std::size_t kRescueExtraCaps = 8;  // more tets above skewness 0.8, at most

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

/// Beyond the paper: slivers (small dihedral) and remaining caps, worst first: flips with the
/// combined objective, then moves of their interior nodes, then conditional node removal.
void RefineOps::slivers() {
    const double threshold = 1.0 - params_.sliver_dihedral_deg / kRegularDihedralDeg;
    const double target = std::min(threshold, 0.8);
    settled_.assign(static_cast<std::size_t>(topo_.tet_capacity()), 0);  // a new objective
    // After the sliver_sweeps full sweeps, up to kSliverOnlySweeps more over the tets under
    // kSliverFloorDeg alone (Combined cost above 1): a change in a late sweep can leave such a
    // sliver (AICHA region 185: 3.2 deg after 5 sweeps, 7.1 deg after 12), and these few tets
    // are cheap to visit again, where full sweeps cost 4x on a poor input surface. Bounded:
    // at most sliver_sweeps + kSliverOnlySweeps sweeps, each over a finite list.
    constexpr int kSliverOnlySweeps = 7;
    for (int sweep = 0; sweep < params_.sliver_sweeps + kSliverOnlySweeps; ++sweep) {
        const double bound = sweep < params_.sliver_sweeps ? target : 1.0;
        const auto candidates = bad_tets(Objective::Combined, bound);
        if (candidates.empty()) break;
        ++counts.sliver_sweeps;
        settled_.resize(static_cast<std::size_t>(topo_.tet_capacity()), 0);
        std::size_t changed = 0;
        for (const std::int32_t t : candidates) {
            if (!topo_.alive(t) || settled_[static_cast<std::size_t>(t)]) continue;
            if (cost(t, Objective::Combined) <= bound) continue;
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
            if (done)
                ++changed;
            else
                settled_[static_cast<std::size_t>(t)] = 1;
        }
        if (changed == 0) break;
    }
}

namespace {

using Face = std::array<std::int32_t, 3>;

/// The faces of the cavity `cavity` (tet ids) towards the rest of the mesh, seen from inside
/// (the new node sees them positively): faces on walls and faces to tets outside it.
void cavity_boundary(const TetTopology& topo, const std::vector<std::int32_t>& cavity,
                     std::vector<Face>& boundary) {
    boundary.clear();
    for (const std::int32_t c : cavity)
        for (int i = 0; i < 4; ++i) {
            const std::int32_t u = topo.neighbor(c, i);
            if (u >= 0 && std::find(cavity.begin(), cavity.end(), u) != cavity.end()) continue;
            const auto f = tet_face(topo.tet(c), i);  // outward; the new node sees it from inside
            boundary.push_back({f[0], f[2], f[1]});
        }
}

/// What the node is placed for: fewest tets above skewness 0.8, then the smallest largest cost
/// (on a poor input triangle the dihedral term alone, as tet_cost), then the largest smallest
/// dihedral angle.
struct Score {
    std::size_t over = 0;
    double min_dihedral = 180.0, max_cost = 0.0;
    bool valid = false;
};

/// The scores of the positions of a new node joined to every face of one cavity's boundary,
/// against the cavity's tets as they are (`old`). With `rescue` the smallest dihedral angle
/// comes first, up to kRescueTargetDeg, and kRescueExtraCaps more tets above 0.8 are allowed.
class NodePlacement {
public:
    NodePlacement(const TetTopology& topo, const RefineOps& ops, const std::vector<Face>& boundary,
                  Objective objective, bool rescue, const Score& old)
        : topo_(topo),
          ops_(ops),
          boundary_(boundary),
          objective_(objective),
          rescue_(rescue),
          old_(old) {}

    Score score(const V3& p) const {
        Score s;
        for (const auto& f : boundary_) {
            const double *a = topo_.xyz(f[0]), *b = topo_.xyz(f[1]), *c = topo_.xyz(f[2]);
            if (!positive_tet(a, b, c, p.data())) return s;
            for (const std::int32_t w : f)  // tetra.max_edge_length: the new node's edges
                if (!ops_.is_within_cap(-1, p.data(), w, topo_.xyz(w))) return s;
            const TetShape shape = tet_shape(a, b, c, p.data(), true);
            s.over += shape.skewness > 0.8 ? 1 : 0;
            if (s.over > old_.over + (rescue_ ? kRescueExtraCaps : 0))
                return s;  // never kept: not worth finishing
            s.min_dihedral = std::min(s.min_dihedral, shape.min_dihedral_deg);
            s.max_cost = std::max(s.max_cost,
                                  objective_ == Objective::Skewness
                                      ? shape.skewness
                                      : combined_cost(shape, topo_.is_poor_face(f[0], f[1], f[2])));
        }
        s.valid = true;
        return s;
    }

    bool better(const Score& x, const Score& y) const {
        if (x.valid != y.valid) return x.valid;
        if (rescue_) {  // the smallest angle first, up to the rescue target
            const double dx = std::min(x.min_dihedral, kRescueTargetDeg);
            const double dy = std::min(y.min_dihedral, kRescueTargetDeg);
            if (dx != dy) return dx > dy;
        }
        if (x.over != y.over) return x.over < y.over;
        if (x.max_cost != y.max_cost) return x.max_cost < y.max_cost;
        return x.min_dihedral > y.min_dihedral;
    }

private:
    const TetTopology& topo_;
    const RefineOps& ops_;
    const std::vector<Face>& boundary_;
    const Objective objective_;
    const bool rescue_;
    const Score old_;
};

/// The cavity's tets as they are: count above 0.8 and smallest dihedral angle (the largest cost
/// is the caller's, through the shape cache).
Score current_score(const TetTopology& topo, const std::vector<std::int32_t>& cavity) {
    Score old;
    old.valid = true;
    for (const std::int32_t c : cavity) {
        const Tet& q = topo.tet(c);
        const TetShape shape =
            tet_shape(topo.xyz(q[0]), topo.xyz(q[1]), topo.xyz(q[2]), topo.xyz(q[3]), true);
        old.over += shape.skewness > 0.8 ? 1 : 0;
        old.min_dihedral = std::min(old.min_dihedral, shape.min_dihedral_deg);
    }
    return old;
}

/// Starting positions for the node: the ideal apex over each boundary face, on its inner side
/// (height sqrt(2/3) of its mean edge), the centroids of t and of the boundary nodes and their
/// midpoint; with `rescue` also the deepest point of the cavity's kernel and two midpoints.
/// Returns the mean boundary edge length h and the boundary nodes' centroid.
std::pair<double, V3> node_candidates(const TetTopology& topo, std::int32_t t,
                                      const std::vector<Face>& boundary, bool rescue,
                                      std::vector<V3>& candidates) {
    candidates.clear();
    V3 centroid_t = V3::Zero(), centroid_b = V3::Zero();
    for (const std::int32_t v : topo.tet(t)) centroid_t += topo.point(v) / 4.0;
    double h = 0.0;
    for (const auto& f : boundary) {
        const V3 a = topo.point(f[0]), b = topo.point(f[1]), c = topo.point(f[2]);
        const V3 n = (b - a).cross(c - a);  // towards the inside: (a, b, c, p) positive
        const double edge = ((b - a).norm() + (c - b).norm() + (a - c).norm()) / 3.0;
        h += edge;
        centroid_b += a + b + c;
        if (n.norm() > 0.0)
            candidates.push_back((a + b + c) / 3.0 + std::sqrt(2.0 / 3.0) * edge * n.normalized());
    }
    h /= static_cast<double>(boundary.size());
    centroid_b /= static_cast<double>(3 * boundary.size());
    candidates.push_back(centroid_t);
    candidates.push_back(centroid_b);
    candidates.push_back(0.5 * (centroid_t + centroid_b));
    if (rescue) {
        // The deepest point of the cavity's kernel (largest smallest height over the boundary
        // face planes), by subgradient steps along the normal of the lowest face: the kernel of
        // a thin cavity can miss every point above. 200 steps.
        std::vector<V3> unit(boundary.size()), on_plane(boundary.size());
        for (std::size_t i = 0; i < boundary.size(); ++i) {
            const V3 a = topo.point(boundary[i][0]), b = topo.point(boundary[i][1]),
                     c = topo.point(boundary[i][2]);
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
    return {h, centroid_b};
}

/// The best of `candidates` (centroid_b when none is valid), then a small deterministic search
/// around it (4 step sizes times 12 offsets, fixed from the tet id t).
std::pair<V3, Score> best_position(const NodePlacement& placement,
                                   const std::vector<V3>& candidates, const V3& centroid_b,
                                   double h, std::int32_t t) {
    V3 best_p = centroid_b;
    Score best;
    for (const V3& p : candidates) {
        const Score s = placement.score(p);
        if (placement.better(s, best)) best = s, best_p = p;
    }
    OffsetSequence offsets(t);
    auto next = [&]() { return offsets.next(); };
    for (const double step : {0.3, 0.15, 0.07, 0.03})
        for (int k = 0; k < 12; ++k) {
            const V3 d(next(), next(), next());
            if (d.norm() < 1e-6) continue;
            const V3 p = best_p + step * h * d.normalized();
            const Score s = placement.score(p);
            if (placement.better(s, best)) best = s, best_p = p;
        }
    return {best_p, best};
}

}  // namespace

bool RefineOps::insertion_cavity(std::int32_t t, int variant) {
    const Tet t_nodes = topo_.tet(t);
    if (variant < 6) {
        // The ring of an edge of t not on a wall: the node splits the edge, then moves.
        static constexpr int kEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
        if (!topo_.edge_ring(t_nodes[static_cast<std::size_t>(kEdge[variant][0])],
                             t_nodes[static_cast<std::size_t>(kEdge[variant][1])], t, ring_tets_,
                             ring_))
            return false;
        cavity_ = ring_tets_;
        return true;
    }
    if (variant >= 8) {
        // The star of an interior node of t: the new node takes its place, so this is a move
        // of that node, searched as widely as a new node's position.
        const std::int32_t v = t_nodes[static_cast<std::size_t>(variant - 8)];
        return !topo_.is_surface_node(v) && topo_.star(v, cavity_);
    }
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
    return true;
}

bool RefineOps::insert_node(std::int32_t t, Objective objective) {
    constexpr std::size_t kMaxCavity = 40;
    const core::Label region = topo_.region(t);
    std::vector<Face> boundary;
    std::vector<V3> candidates;
    // The chosen cavity, boundary and node among the variants.
    std::vector<std::int32_t> chosen_cavity;
    std::vector<Face> chosen_boundary;
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
    const bool rescue = tet_shape(topo_.xyz(t_nodes[0]), topo_.xyz(t_nodes[1]),
                                  topo_.xyz(t_nodes[2]), topo_.xyz(t_nodes[3]), true)
                            .min_dihedral_deg < kRescueDihedralDeg;
    // Twelve cavities: the rings of t's six edges, t with one and two layers of neighbours, and
    // the stars of t's interior nodes.
    for (int variant = 0; variant < 12; ++variant) {
        if (!insertion_cavity(t, variant) || cavity_.size() > kMaxCavity) continue;
        cavity_boundary(topo_, cavity_, boundary);
        if (!is_sphere(boundary)) continue;
        Score old = current_score(topo_, cavity_);
        old.max_cost = max_cost(cavity_, objective);
        const NodePlacement placement(topo_, *this, boundary, objective, rescue, old);
        const auto [h, centroid_b] = node_candidates(topo_, t, boundary, rescue, candidates);
        const auto [best_p, best] = best_position(placement, candidates, centroid_b, h, t);
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
    fill_cavity(chosen_cavity, chosen_boundary, chosen_p, region);
    return true;
}

void RefineOps::fill_cavity(std::span<const std::int32_t> cavity,
                            std::span<const std::array<std::int32_t, 3>> boundary, const V3& p,
                            core::Label region) {
    // the node's level: the highest of the cavity's nodes
    std::int32_t level = 0;
    if (!topo_.mesh().level.empty())
        for (const std::int32_t c : cavity)
            for (const std::int32_t v : topo_.tet(c))
                level = std::max(level, topo_.mesh().level[static_cast<std::size_t>(v)]);
    prepare_cache();
    const std::int32_t v = topo_.add_node(p, level);
    edited({});  // a new node changes no tet yet
    candidate_.clear();
    for (const auto& f : boundary) candidate_.push_back({f[0], f[1], f[2], v});
    apply(cavity, candidate_, region);
}

}  // namespace frontmesh::volume
