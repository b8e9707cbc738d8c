// Edge splits of the refine stage for the volume size cap (tetra.max_edge_length).

#include <algorithm>
#include <array>
#include <cstdint>
#include <tuple>
#include <vector>

#include "volume/refine_ops.h"

namespace frontmesh::volume {

bool RefineOps::split_edge(std::int32_t a, std::int32_t b, std::int32_t t) {
    if (!topo_.edge_ring(a, b, t, ring_tets_, ring_)) return false;  // on a wall
    const Eigen::Vector3d m = 0.5 * (topo_.point(a) + topo_.point(b));
    const double* pa = topo_.xyz(a);
    const double* pb = topo_.xyz(b);
    const double pm[3] = {m.x(), m.y(), m.z()};
    // (a, b, r_k, r_k+1) is positive; m on the segment keeps both halves positive in exact
    // arithmetic, but the rounded midpoint may leave a nearly flat tet's half flat: checked.
    const std::size_t n = ring_.size();
    for (std::size_t k = 0; k < n; ++k) {
        const double* c = topo_.xyz(ring_[k]);
        const double* d = topo_.xyz(ring_[(k + 1) % n]);
        if (!positive_tet(pm, pb, c, d) || !positive_tet(pa, pm, c, d)) return false;
    }
    std::int32_t level = 0;
    if (!topo_.mesh().level.empty())
        level = std::max(topo_.mesh().level[static_cast<std::size_t>(a)],
                         topo_.mesh().level[static_cast<std::size_t>(b)]);
    const core::Label region = topo_.region(t);
    const std::vector<std::int32_t> old_tets = ring_tets_;
    const std::vector<std::int32_t> ring = ring_;
    prepare_cache();
    const std::int32_t v = topo_.add_node(m, level);
    edited({});  // a new node changes no tet yet
    candidate_.clear();
    for (std::size_t k = 0; k < n; ++k) {
        const std::int32_t c = ring[k], d = ring[(k + 1) % n];
        candidate_.push_back({v, b, c, d});
        candidate_.push_back({a, v, c, d});
    }
    apply(old_tets, candidate_, region);
    ++counts.edge_splits;
    return true;
}

void RefineOps::set_edge_cap(double max_length) {
    cap2_ = max_length > 0.0 ? max_length * max_length : 0.0;
    if (cap2_ > 0.0) index_surface_edges();
}

void RefineOps::index_surface_edges() {
    // The cap of an edge: max_length, or the longest surface edge at either of its nodes
    // when that is longer. The surface is kept, so a tet on a surface triangle of edges
    // longer than the cap cannot have all its edges within the cap: splitting its other
    // edges would only cascade into slivers at the triangle. With the local cap a point
    // within reach of a triangle's corners (its circumcentre lifted off it) always fits.
    if (!surface_edge2_.empty() || topo_.mesh().surface_vertices == 0) return;
    surface_edge2_.assign(static_cast<std::size_t>(topo_.mesh().surface_vertices), 0.0);
    for (const auto& f : topo_.mesh().faces)
        for (int k = 0; k < 3; ++k) {
            const std::int32_t a = f[static_cast<std::size_t>(k)],
                               b = f[static_cast<std::size_t>((k + 1) % 3)];
            const double l2 = (topo_.point(a) - topo_.point(b)).squaredNorm();
            for (const std::int32_t v : {a, b})
                if (static_cast<std::size_t>(v) < surface_edge2_.size())
                    surface_edge2_[static_cast<std::size_t>(v)] =
                        std::max(surface_edge2_[static_cast<std::size_t>(v)], l2);
        }
}

bool RefineOps::is_within(std::int32_t a, const double* pa, std::int32_t b, const double* pb,
                          double max2) const {
    const auto at = [&](std::int32_t v) {
        return v >= 0 && static_cast<std::size_t>(v) < surface_edge2_.size()
                   ? surface_edge2_[static_cast<std::size_t>(v)]
                   : 0.0;  // an interior node, or one added by refine
    };
    const double dx = pa[0] - pb[0], dy = pa[1] - pb[1], dz = pa[2] - pb[2];
    return dx * dx + dy * dy + dz * dz <= std::max(max2, std::max(at(a), at(b)));
}

bool RefineOps::is_within_cap(std::int32_t a, const double* pa, std::int32_t b,
                              const double* pb) const {
    return cap2_ == 0.0 || is_within(a, pa, b, pb, cap2_);
}

bool RefineOps::is_within_cap(const Tet& t) const {
    if (cap2_ == 0.0) return true;
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
            const std::int32_t a = t[static_cast<std::size_t>(i)],
                               b = t[static_cast<std::size_t>(j)];
            if (!is_within(a, topo_.xyz(a), b, topo_.xyz(b), cap2_)) return false;
        }
    return true;
}

std::size_t RefineOps::split_long_edges(double max_length) {
    index_surface_edges();
    const double max2 = max_length * max_length;
    auto is_long = [&](std::int32_t a, std::int32_t b) {
        return !is_within(a, topo_.xyz(a), b, topo_.xyz(b), max2);
    };
    // An edge is listed with one tet holding it: (-length^2, a, b, t) so that sorting puts
    // the longest first, ties by node ids.
    std::vector<std::tuple<double, std::int32_t, std::int32_t, std::int32_t>> edges;
    auto collect = [&] {
        edges.clear();
        for (std::int32_t t = 0; t < topo_.tet_capacity(); ++t) {
            if (!topo_.alive(t)) continue;
            const Tet& q = topo_.tet(t);
            for (int i = 0; i < 4; ++i)
                for (int j = i + 1; j < 4; ++j) {
                    const std::int32_t a = std::min(q[i], q[j]), b = std::max(q[i], q[j]);
                    if (!is_long(a, b)) continue;
                    edges.emplace_back(-(topo_.point(a) - topo_.point(b)).squaredNorm(), a, b, t);
                }
        }
        std::sort(edges.begin(), edges.end());
        // Each edge once (the first listing: the smallest tet id after the length and ids).
        edges.erase(std::unique(edges.begin(), edges.end(),
                                [](const auto& x, const auto& y) {
                                    return std::get<1>(x) == std::get<1>(y) &&
                                           std::get<2>(x) == std::get<2>(y);
                                }),
                    edges.end());
    };
    // Bound: at most kMaxSplitRounds rounds, each splitting every long edge listed at its
    // start at most once. A split of (a, b) leaves edges a-m and m-b of half the length and
    // edges m-r_k no longer than max(|a r_k|, |b r_k|) (distance to a point of a segment), so
    // no split makes the longest edge longer, and the long edges listed shrink away round by
    // round (longest-edge bisection). Edges that stay (on a wall's ring, a split that would
    // not be positive, or the rounds spent) are counted and reported by the caller.
    std::size_t left = 0;
    for (int round = 0; round < kMaxSplitRounds; ++round) {
        collect();
        left = 0;
        std::size_t split = 0;
        for (const auto& [neg_l2, a, b, t] : edges) {
            (void)neg_l2;
            // The tet listed may have been replaced by an earlier split of this round (ids are
            // reused): the edge is still there when the tet at that id holds both nodes.
            if (!topo_.alive(t) || local_index(topo_.tet(t), a) < 0 ||
                local_index(topo_.tet(t), b) < 0) {
                ++left;
                continue;
            }
            if (split_edge(a, b, t))
                ++split;
            else
                ++left;
        }
        if (split == 0) break;
    }
    if (left > 0) {  // what the last round could not split, or what it made: count again
        collect();
        left = 0;
        for (const auto& [neg_l2, a, b, t] : edges) {
            (void)neg_l2;
            if (topo_.edge_ring(a, b, t, ring_tets_, ring_)) ++left;
        }
    }
    return left;
}

}  // namespace frontmesh::volume
