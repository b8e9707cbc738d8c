#include "volume/quadratic.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "pipeline/core/error.h"
#include "pipeline/core/quadratic_nodes.h"
#include "surface/front_triangulate.h"

namespace frontmesh::volume {
namespace {

using V3 = Eigen::Vector3d;
using Pair = std::pair<core::Label, core::Label>;  // labels on either side, smaller first

// A projected mid node further than this from the midpoint, in edge lengths, is not taken:
// a sagitta of 0.2 L is a circle of radius 0.625 L through both nodes, a curvature the
// straight edges could not have followed; farther points belong to another sheet.
constexpr double kMaxSagitta = 0.2;

// Index of a cubic multi-index alpha (alpha_1, alpha_2, alpha_3; alpha_0 = 3 - the rest) in
// a 4 x 4 x 4 table.
int alpha_index(int a, int b, int c) {
    int n[4] = {0, 0, 0, 0};
    ++n[a];
    ++n[b];
    ++n[c];
    return n[1] + 4 * n[2] + 16 * n[3];
}

double scaled_jacobian(const core::TetMesh& mesh, std::size_t t, const std::vector<V3>& mid,
                       const std::array<std::int32_t, 6>& edges) {
    std::array<V3, 10> x;
    for (int k = 0; k < 4; ++k) x[static_cast<std::size_t>(k)] = mesh.point(mesh.tets[t][k]);
    for (int k = 0; k < 6; ++k)
        x[static_cast<std::size_t>(4 + k)] = mid[static_cast<std::size_t>(edges[k])];
    const double straight = (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0]));
    return straight > 0.0 ? min_bezier_jacobian(x) / straight : -1.0;
}

}  // namespace

double min_bezier_jacobian(const std::array<Eigen::Vector3d, 10>& x) {
    // Bezier control net of the quadratic map x(lambda) = sum_ij lambda_i lambda_j P_ij:
    // P_ii = corner i, P_ij = 2 m_ij - (x_i + x_j) / 2 (m_ij the mid node of edge ij), so
    // that the map passes through m_ij at lambda_i = lambda_j = 1/2.
    V3 P[4][4];
    for (int i = 0; i < 4; ++i) P[i][i] = x[static_cast<std::size_t>(i)];
    for (int k = 0; k < 6; ++k) {
        const int i = core::kTetEdge[k][0], j = core::kTetEdge[k][1];
        P[i][j] = P[j][i] = 2.0 * x[static_cast<std::size_t>(4 + k)] -
                            0.5 * (x[static_cast<std::size_t>(i)] + x[static_cast<std::size_t>(j)]);
    }
    // With xi_k = lambda_k (k = 1..3), lambda_0 = 1 - sum: dx/dxi_k = sum_j lambda_j D[k][j],
    // D[k][j] = 2 (P_kj - P_0j), linear in lambda. det J = sum_abc lambda_a lambda_b lambda_c
    // det(D[1][a], D[2][b], D[3][c]); the Bernstein coefficient of lambda^alpha (B = 3!/alpha!
    // lambda^alpha) is the mean of det(...) over the ordered (a, b, c) with e_a + e_b + e_c =
    // alpha.
    V3 D[4][4];
    for (int k = 1; k < 4; ++k)
        for (int j = 0; j < 4; ++j) D[k][j] = 2.0 * (P[k][j] - P[0][j]);
    double sum[64] = {};
    int count[64] = {};
    for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b)
            for (int c = 0; c < 4; ++c) {
                const int i = alpha_index(a, b, c);
                sum[i] += D[1][a].dot(D[2][b].cross(D[3][c]));
                ++count[i];
            }
    double lowest = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 64; ++i)
        if (count[i] > 0) lowest = std::min(lowest, sum[i] / count[i]);
    return lowest;
}

core::TetMesh elevate_to_quadratic(const core::TetMesh& mesh,
                                   const core::SurfaceNetwork* background, QuadraticStats* stats) {
    FM_CHECK(!mesh.is_quadratic());
    const core::QuadraticNodes q = core::quadratic_nodes(mesh);
    const std::size_t ne = q.edges.size();
    QuadraticStats st;
    st.edges = ne;

    // The surface of each edge: the label pair of the faces on it; kJunction where faces of
    // two different pairs meet (a curve between three regions, or a region's boundary
    // meeting an interface), kInterior for no face.
    constexpr std::int32_t kInterior = -1, kJunction = -2;
    std::map<Pair, std::int32_t> pair_id;
    std::vector<Pair> pairs;
    std::vector<std::int32_t> edge_pair(ne, kInterior);
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        const Pair key{std::min(mesh.region_in[f], mesh.region_out[f]),
                       std::max(mesh.region_in[f], mesh.region_out[f])};
        const auto [it, added] = pair_id.emplace(key, static_cast<std::int32_t>(pairs.size()));
        if (added) pairs.push_back(key);
        for (const std::int32_t e : q.face_edges[f]) {
            std::int32_t& p = edge_pair[static_cast<std::size_t>(e)];
            p = p == kInterior || p == it->second ? it->second : kJunction;
        }
    }

    // One projector per pair of labels: the background faces between them (remesh projected
    // the surface vertices onto the same faces, so the corners already lie on them).
    std::vector<std::unique_ptr<surface::BackgroundPatch>> patch(pairs.size());
    if (background != nullptr) {
        std::vector<std::vector<std::int32_t>> faces(pairs.size());
        for (std::size_t f = 0; f < background->face_count(); ++f) {
            const Pair key{std::min(background->region_in[f], background->region_out[f]),
                           std::max(background->region_in[f], background->region_out[f])};
            if (const auto it = pair_id.find(key); it != pair_id.end())
                faces[static_cast<std::size_t>(it->second)].push_back(static_cast<std::int32_t>(f));
        }
        for (std::size_t p = 0; p < pairs.size(); ++p)
            if (!faces[p].empty())
                patch[p] = std::make_unique<surface::BackgroundPatch>(*background,
                                                                      std::move(faces[p]), false);
    }

    // Copies of one edge (split interfaces): keyed by the nodes they copy. The group of an
    // edge is its index in `groups`; members listed in CSR order.
    std::vector<std::int32_t> group(ne);
    std::vector<std::int32_t> representative;  // per group: the edge whose nodes are originals
    {
        const bool split = !mesh.twin.empty();
        std::unordered_map<std::uint64_t, std::int32_t> by_original;
        for (std::size_t e = 0; e < ne; ++e) {
            std::int32_t a = q.edges[e][0], b = q.edges[e][1];
            if (split) {
                a = mesh.twin[static_cast<std::size_t>(a)];
                b = mesh.twin[static_cast<std::size_t>(b)];
            }
            const std::uint64_t key =
                (std::uint64_t{static_cast<std::uint32_t>(std::min(a, b))} << 32) |
                static_cast<std::uint32_t>(std::max(a, b));
            const auto [it, added] =
                by_original.emplace(key, static_cast<std::int32_t>(representative.size()));
            if (added) representative.push_back(static_cast<std::int32_t>(e));
            group[e] = it->second;
            const bool original =
                !split || (mesh.twin[static_cast<std::size_t>(q.edges[e][0])] == q.edges[e][0] &&
                           mesh.twin[static_cast<std::size_t>(q.edges[e][1])] == q.edges[e][1]);
            if (original)
                representative[static_cast<std::size_t>(it->second)] = static_cast<std::int32_t>(e);
        }
    }
    const std::size_t ng = representative.size();
    std::vector<std::int32_t> group_start(ng + 1, 0), group_edges(ne);
    for (std::size_t e = 0; e < ne; ++e) ++group_start[static_cast<std::size_t>(group[e]) + 1];
    for (std::size_t g = 0; g < ng; ++g) group_start[g + 1] += group_start[g];
    {
        std::vector<std::int32_t> fill(group_start.begin(), group_start.end() - 1);
        for (std::size_t e = 0; e < ne; ++e)
            group_edges[static_cast<std::size_t>(fill[static_cast<std::size_t>(group[e])]++)] =
                static_cast<std::int32_t>(e);
    }

    // Placement, per group (its copies lie at the same place): the representative's midpoint,
    // projected for a surface edge.
    std::vector<V3> mid(ne);
    std::vector<char> curved(ne, 0);
    for (std::size_t g = 0; g < ng; ++g) {
        const auto e = static_cast<std::size_t>(representative[g]);
        const V3 a = mesh.point(q.edges[e][0]), b = mesh.point(q.edges[e][1]);
        V3 m = 0.5 * (a + b);
        bool is_curved = false;
        const std::int32_t p = edge_pair[e];
        if (p != kInterior) {
            st.surface_edges += static_cast<std::size_t>(group_start[g + 1] - group_start[g]);
            if (p >= 0 && patch[static_cast<std::size_t>(p)]) {
                const auto& bg = *patch[static_cast<std::size_t>(p)];
                // Corners moved off the background by remesh.preserve_volume (at most h / 10):
                // the mid node follows the background shifted by their mean offset, so the
                // edge bends as the background does instead of dipping back onto it.
                const V3 shift = 0.5 * ((a - bg.project(a).point) + (b - bg.project(b).point));
                const V3 placed = bg.project(m).point + shift;
                const double distance = (placed - m).norm();
                if (distance <= kMaxSagitta * (b - a).norm()) {
                    is_curved = distance > 0.0;
                    m = placed;
                } else {
                    ++st.not_projected;
                }
            } else {
                ++st.not_projected;
            }
        }
        for (std::int32_t i = group_start[g]; i < group_start[g + 1]; ++i) {
            const auto e2 = static_cast<std::size_t>(group_edges[static_cast<std::size_t>(i)]);
            mid[e2] = m;
            curved[e2] = is_curved ? 1 : 0;
        }
    }

    // Tets on each edge (CSR), to re-check the tets of an edge taken back.
    std::vector<std::int32_t> edge_start(ne + 1, 0), edge_tets(6 * mesh.tet_count());
    for (const auto& te : q.tet_edges)
        for (const std::int32_t e : te) ++edge_start[static_cast<std::size_t>(e) + 1];
    for (std::size_t e = 0; e < ne; ++e) edge_start[e + 1] += edge_start[e];
    {
        std::vector<std::int32_t> fill(edge_start.begin(), edge_start.end() - 1);
        for (std::size_t t = 0; t < mesh.tet_count(); ++t)
            for (const std::int32_t e : q.tet_edges[t])
                edge_tets[static_cast<std::size_t>(fill[static_cast<std::size_t>(e)]++)] =
                    static_cast<std::int32_t>(t);
    }

    // Validity: a tet below kMinScaledJacobian gets its curved edge of largest displacement
    // (ties: smallest edge id) straightened, with all its copies, and every tet on those
    // edges is checked again. Bound: each step straightens at least one curved edge for good
    // (nothing curves an edge again), so at most `curved edges` steps; each step queues at
    // most the tets of its edges, so the queue empties. A tet left with no curved edge has
    // every Bernstein coefficient equal to its straight Jacobian (scaled bound 1), and the
    // input tets are positive: the loop always ends with every tet valid.
    std::deque<std::int32_t> queue;
    std::vector<char> queued(mesh.tet_count(), 0);
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        for (const std::int32_t e : q.tet_edges[t])
            if (curved[static_cast<std::size_t>(e)] && !queued[t]) {
                queued[t] = 1;
                queue.push_back(static_cast<std::int32_t>(t));
            }
    while (!queue.empty()) {
        const auto t = static_cast<std::size_t>(queue.front());
        queue.pop_front();
        queued[t] = 0;
        if (scaled_jacobian(mesh, t, mid, q.tet_edges[t]) >= kMinScaledJacobian) continue;
        std::int32_t worst = -1;
        double worst_d = -1.0;
        for (const std::int32_t e : q.tet_edges[t]) {
            const auto ue = static_cast<std::size_t>(e);
            if (!curved[ue]) continue;
            const double d =
                (mid[ue] - 0.5 * (mesh.point(q.edges[ue][0]) + mesh.point(q.edges[ue][1])))
                    .squaredNorm();
            if (d > worst_d || (d == worst_d && e < worst)) {
                worst = e;
                worst_d = d;
            }
        }
        // Straight edges only: scaled bound 1 up to rounding; a tet whose straight Jacobian
        // rounds to zero or below (positive by the exact predicate) is left as it is.
        if (worst < 0) continue;
        const auto g = static_cast<std::size_t>(group[static_cast<std::size_t>(worst)]);
        for (std::int32_t i = group_start[g]; i < group_start[g + 1]; ++i) {
            const auto e = static_cast<std::size_t>(group_edges[static_cast<std::size_t>(i)]);
            curved[e] = 0;
            mid[e] = 0.5 * (mesh.point(q.edges[e][0]) + mesh.point(q.edges[e][1]));
            for (std::int32_t k = edge_start[e]; k < edge_start[e + 1]; ++k) {
                const auto u = static_cast<std::size_t>(edge_tets[static_cast<std::size_t>(k)]);
                if (!queued[u]) {
                    queued[u] = 1;
                    queue.push_back(static_cast<std::int32_t>(u));
                }
            }
        }
        ++st.straightened;
        if (!queued[t]) {
            queued[t] = 1;
            queue.push_back(static_cast<std::int32_t>(t));
        }
    }

    core::TetMesh out = mesh;
    const auto n = static_cast<std::int32_t>(mesh.node_count());
    out.xyz.reserve(mesh.xyz.size() + 3 * ne);
    for (std::size_t e = 0; e < ne; ++e) {
        out.add_node(mid[e]);
        st.curved += curved[e] ? 1 : 0;
    }
    out.tet_mid.resize(mesh.tet_count());
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        for (int k = 0; k < 6; ++k)
            out.tet_mid[t][static_cast<std::size_t>(k)] = n + q.tet_edges[t][k];
    out.face_mid.resize(mesh.face_count());
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        for (int k = 0; k < 3; ++k)
            out.face_mid[f][static_cast<std::size_t>(k)] = n + q.face_edges[f][k];
    if (!mesh.level.empty())
        for (std::size_t e = 0; e < ne; ++e)
            out.level.push_back(std::max(mesh.level[static_cast<std::size_t>(q.edges[e][0])],
                                         mesh.level[static_cast<std::size_t>(q.edges[e][1])]));
    if (!mesh.twin.empty())
        for (std::size_t e = 0; e < ne; ++e)
            out.twin.push_back(n + representative[static_cast<std::size_t>(group[e])]);
    st.min_scaled_jacobian = 1.0;
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        st.min_scaled_jacobian =
            std::min(st.min_scaled_jacobian, scaled_jacobian(mesh, t, mid, q.tet_edges[t]));
    if (stats) *stats = st;
    return out;
}

}  // namespace frontmesh::volume
