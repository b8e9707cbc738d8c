// Curves and loops of the remesh stage (paper §2: "by specifying node distribution on the
// features, the local mesh density can be easily controlled"): each feature curve is cut by
// the size field (with the retry policy's multipliers) into points shared by the patches it
// bounds, and the patches' boundary loops are read off those points.

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <unordered_map>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "surface/remesh_internal.h"

namespace frontmesh::surface::remesh_detail {

namespace {

// A background face next to segment (cv[i], cv[i + 1]) of a curve polyline, for size queries.
std::int32_t curve_segment_face(const EdgeTable& edges, const std::vector<std::int32_t>& cv,
                                std::size_t i) {
    const std::int32_t a = std::min(cv[i], cv[i + 1]), b = std::max(cv[i], cv[i + 1]);
    const auto it = std::lower_bound(edges.vertices.begin(), edges.vertices.end(),
                                     std::array<std::int32_t, 2>{a, b});
    FM_CHECK(it != edges.vertices.end() && (*it)[0] == a && (*it)[1] == b);
    return edges
        .edge_faces[std::size_t(edges.face_offsets[std::size_t(it - edges.vertices.begin())])];
}

DiscreteCurve discretise(const core::SurfaceNetwork& bg, const FeatureCurve& curve,
                         const std::function<double(std::int32_t)>& vertex_size,
                         const EdgeTable& edges, int min_segments) {
    const auto& cv = curve.vertices;
    const std::size_t n = cv.size();
    std::vector<double> arc(n, 0.0), integral(n, 0.0);
    for (std::size_t i = 1; i < n; ++i) {
        const double len = (bg.point(cv[i]) - bg.point(cv[i - 1])).norm();
        arc[i] = arc[i - 1] + len;
        // Trapezoid rule for the integral of 1/h along the segment.
        integral[i] =
            integral[i - 1] + 0.5 * len * (1.0 / vertex_size(cv[i - 1]) + 1.0 / vertex_size(cv[i]));
    }
    const double total = integral.back();
    const int segments = std::max(min_segments, static_cast<int>(std::lround(total)));
    auto segment_face = [&](std::size_t i) { return curve_segment_face(edges, cv, i); };
    DiscreteCurve out;
    out.points.push_back(bg.point(cv.front()));
    out.s.push_back(0.0);
    out.faces.push_back(segment_face(0));
    std::size_t i = 0;
    for (int k = 1; k < segments; ++k) {
        const double target = total * k / segments;
        while (i + 2 < n && integral[i + 1] < target) ++i;
        const double span = integral[i + 1] - integral[i];
        const double t = span > 0.0 ? std::clamp((target - integral[i]) / span, 0.0, 1.0) : 0.0;
        out.points.push_back((1.0 - t) * bg.point(cv[i]) + t * bg.point(cv[i + 1]));
        out.s.push_back(arc[i] + t * (arc[i + 1] - arc[i]));
        out.faces.push_back(segment_face(i));
    }
    out.points.push_back(bg.point(cv.back()));
    out.s.push_back(arc.back());
    out.faces.push_back(segment_face(n - 2));
    out.bg_vertex.assign(out.points.size(), -1);
    out.bg_vertex.front() = cv.front();
    out.bg_vertex.back() = cv.back();
    return out;
}

// A curve edge shorter than this times h is merged away on a full-resolution curve: a
// marching-cubes background has edges of a hundredth of a voxel, and such an edge on a curve
// leaves a needle on either side that no smoothing mends (ch2-head: 0.014 mm, 0.8 degrees).
constexpr double kMergeCurveEdgeBelow = 0.2;
// A face with a smaller angle than this (degrees) is a needle: its normal is noise.
constexpr double kNeedleDeg = 1.0;

// The copied patches' faces around background vertices, and the merges made so far: a merge
// of curve vertex v into its curve neighbour u is the edge collapse (u, v) -> u in every
// copied patch on the curve. It is made only where it is valid on the background as it was:
// neither u nor v took part in a merge, no vertex of a face around them was merged away (so
// the merges are independent: each is checked on the faces it changes, unchanged), each
// copied patch has exactly one face on the edge, whose third vertex is on no curve or is v's
// other curve neighbour (then the edge from u to it keeps a face), u and v share no other
// neighbour in the patch (the link condition: the result stays a 2-manifold), and every face
// that stays keeps its side (unless it was a needle, whose normal is noise) and becomes no
// new needle unless it has an edge shorter than the merge length (the patch's own collapses,
// coarsen_patch light, take it).
class CurveMerges {
public:
    CurveMerges(const core::SurfaceNetwork& bg, const Features& features, const RetryPolicy& retry)
        : bg_(bg), features_(features) {
        const std::size_t nv = bg.vertex_count();
        offsets_.assign(nv + 1, 0);
        std::vector<std::int32_t> faces;
        for (std::size_t p = 0; p < features.patches.size(); ++p)
            if (retry.copy(p))
                for (const std::int32_t f : features.patches[p].faces) faces.push_back(f);
        for (const std::int32_t f : faces)
            for (const std::int32_t v : bg.faces[std::size_t(f)]) ++offsets_[std::size_t(v) + 1];
        for (std::size_t v = 0; v < nv; ++v) offsets_[v + 1] += offsets_[v];
        ring_.resize(offsets_.back());
        std::vector<std::size_t> at(offsets_.begin(), offsets_.end() - 1);
        for (const std::int32_t f : faces)
            for (const std::int32_t v : bg.faces[std::size_t(f)]) ring_[at[std::size_t(v)]++] = f;
        on_curve_.assign(nv, 0);
        for (const auto& c : features.curves)
            for (const std::int32_t v : c.vertices) on_curve_[std::size_t(v)] = 1;
        involved_.assign(nv, 0);
        dropped_.assign(nv, 0);
    }

    // Merges v into u when valid (see the class); true when made. `beyond`: v's other
    // neighbour on the curve; `limit`: the merge length there.
    bool merge(std::int32_t v, std::int32_t u, std::int32_t beyond, double limit) {
        if (involved_[std::size_t(v)] || involved_[std::size_t(u)]) return false;
        for (const std::int32_t w : {u, v})
            for (std::size_t k = offsets_[std::size_t(w)]; k < offsets_[std::size_t(w) + 1]; ++k)
                for (const std::int32_t x : bg_.faces[std::size_t(ring_[k])])
                    if (dropped_[std::size_t(x)]) return false;
        if (!link_holds(u, v, beyond) || !faces_keep_shape(u, v, limit)) return false;
        involved_[std::size_t(u)] = involved_[std::size_t(v)] = 1;
        dropped_[std::size_t(v)] = 1;
        return true;
    }

private:
    bool link_holds(std::int32_t u, std::int32_t v, std::int32_t beyond) const {
        std::map<std::int32_t, std::vector<std::int32_t>> on_edge;   // patch -> apexes
        std::map<std::int32_t, std::vector<std::int32_t>> around_u;  // patch -> neighbours of u
        for (std::size_t k = offsets_[std::size_t(u)]; k < offsets_[std::size_t(u) + 1]; ++k) {
            const std::int32_t f = ring_[k];
            const auto& t = bg_.faces[std::size_t(f)];
            const std::int32_t p = features_.face_patch[std::size_t(f)];
            const bool has_v = t[0] == v || t[1] == v || t[2] == v;
            for (const std::int32_t x : t) {
                if (x == u) continue;
                if (has_v && x != v) on_edge[p].push_back(x);
                if (x != v) around_u[p].push_back(x);
            }
        }
        if (on_edge.empty()) return false;
        for (const auto& [p, apexes] : on_edge) {
            if (apexes.size() != 1) return false;
            const std::int32_t apex = apexes.front();
            if (apex == beyond) {
                // Face (u, v, beyond) goes and the curve runs u-beyond: that edge must keep a
                // face of the patch.
                const auto& nu = around_u.at(p);
                if (std::count(nu.begin(), nu.end(), beyond) < 2) return false;
            } else if (on_curve_[std::size_t(apex)]) {
                return false;
            }
        }
        for (std::size_t k = offsets_[std::size_t(v)]; k < offsets_[std::size_t(v) + 1]; ++k) {
            const std::int32_t f = ring_[k];
            const std::int32_t p = features_.face_patch[std::size_t(f)];
            const auto it = on_edge.find(p);
            if (it == on_edge.end()) return false;  // a copied patch at v but not on the edge
            const auto& nu = around_u[p];
            for (const std::int32_t x : bg_.faces[std::size_t(f)])
                if (x != u && x != v && x != it->second.front() &&
                    std::find(nu.begin(), nu.end(), x) != nu.end())
                    return false;
        }
        return true;
    }

    // Every face around v that stays: not degenerate; a speck (all edges under the merge
    // length) is left to coarsen_patch; else it turns by at most 60 degrees unless it was a
    // needle, and becomes no new needle unless it has an edge under the merge length.
    bool faces_keep_shape(std::int32_t u, std::int32_t v, double limit) const {
        for (std::size_t k = offsets_[std::size_t(v)]; k < offsets_[std::size_t(v) + 1]; ++k) {
            const auto& t = bg_.faces[std::size_t(ring_[k])];
            if (t[0] == u || t[1] == u || t[2] == u) continue;  // the face on the edge goes
            std::array<Eigen::Vector3d, 3> x, y;
            for (int i = 0; i < 3; ++i) {
                x[std::size_t(i)] = bg_.point(t[std::size_t(i)]);
                y[std::size_t(i)] = t[std::size_t(i)] == v ? bg_.point(u) : x[std::size_t(i)];
            }
            const Eigen::Vector3d n0 = (x[1] - x[0]).cross(x[2] - x[0]);
            const Eigen::Vector3d n1 = (y[1] - y[0]).cross(y[2] - y[0]);
            if (!(n1.norm() > 0.0)) return false;
            const std::array<double, 3> edge{(y[1] - y[0]).norm(), (y[2] - y[1]).norm(),
                                             (y[0] - y[2]).norm()};
            if (*std::max_element(edge.begin(), edge.end()) < limit) continue;  // a speck
            const double shortest = *std::min_element(edge.begin(), edge.end());
            const double before = core::triangle_min_angle_deg(x[0], x[1], x[2]);
            const double after = core::triangle_min_angle_deg(y[0], y[1], y[2]);
            if (before > kNeedleDeg && !(n0.dot(n1) > 0.5 * n0.norm() * n1.norm())) return false;
            if (!(after >= std::min(before, kNeedleDeg)) && !(shortest < limit)) return false;
        }
        return true;
    }

    const core::SurfaceNetwork& bg_;
    const Features& features_;
    std::vector<std::size_t> offsets_;
    std::vector<std::int32_t> ring_;
    std::vector<std::uint8_t> on_curve_, involved_, dropped_;
};

// The curve at full resolution: every polyline vertex is a point (the boundary of a patch
// copied from the background), except those merged into a neighbour (CurveMerges) where
// their curve edge is shorter than kMergeCurveEdgeBelow h, while the curve keeps at least
// `min_segments` segments. Each vertex is visited once: O(curve vertices x ring size).
DiscreteCurve discretise_full(const core::SurfaceNetwork& bg, const FeatureCurve& curve,
                              const EdgeTable& edges,
                              const std::function<double(std::int32_t)>& vertex_size,
                              int min_segments, CurveMerges& merges) {
    const auto& cv = curve.vertices;
    const std::size_t n = cv.size();
    std::vector<std::uint8_t> keep(n, 1);
    std::vector<std::array<std::int32_t, 2>> merged;
    std::size_t kept = n;
    for (std::size_t i = 1; i + 1 < n && kept > std::size_t(min_segments) + 1; ++i) {
        const std::int32_t v = cv[i];
        const double limit = kMergeCurveEdgeBelow * vertex_size(v);
        std::array<std::pair<double, std::int32_t>, 2> targets{
            std::pair{keep[i - 1] ? (bg.point(cv[i - 1]) - bg.point(v)).norm()
                                  : std::numeric_limits<double>::infinity(),
                      cv[i - 1]},
            std::pair{(bg.point(cv[i + 1]) - bg.point(v)).norm(), cv[i + 1]}};
        if (targets[1].first < targets[0].first) std::swap(targets[0], targets[1]);
        for (const auto& [length, u] : targets) {
            const std::int32_t other = u == cv[i - 1] ? cv[i + 1] : cv[i - 1];
            if (!(length < limit) || cv[i - 1] == cv[i + 1] || !merges.merge(v, u, other, limit))
                continue;
            keep[i] = 0;
            --kept;
            merged.push_back({v, u});
            break;
        }
    }
    DiscreteCurve out;
    double arc = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        if (i > 0) arc += (bg.point(cv[i]) - bg.point(cv[i - 1])).norm();
        if (!keep[i]) continue;
        out.points.push_back(bg.point(cv[i]));
        out.s.push_back(arc);
        out.faces.push_back(curve_segment_face(edges, cv, std::min(i, n - 2)));
        out.bg_vertex.push_back(cv[i]);
    }
    out.merged = std::move(merged);
    return out;
}

// Segments at least: 3 on a closed curve or one from a corner back to itself, 2 when two
// curves join the same two corners (they would otherwise be one edge twice), else 1.
int min_segments_of(const FeatureCurve& c,
                    const std::map<std::pair<std::int32_t, std::int32_t>, int>& end_pairs) {
    const std::int32_t a = c.vertices.front(), b = c.vertices.back();
    if (c.is_closed || a == b) return 3;
    if (end_pairs.at({std::min(a, b), std::max(a, b)}) > 1) return 2;
    return 1;
}

}  // namespace

std::vector<DiscreteCurve> place_curve_points(const core::SurfaceNetwork& bg,
                                              const Features& features, const RetryPolicy& retry,
                                              core::SurfaceNetwork& out,
                                              std::vector<std::int32_t>& vertex_face) {
    std::map<std::int32_t, std::int32_t> corner_id;
    for (const std::int32_t v : features.corners) {
        corner_id[v] = out.add_vertex(bg.point(v));
        vertex_face.push_back(-1);
    }
    std::map<std::pair<std::int32_t, std::int32_t>, int> end_pairs;
    for (const auto& c : features.curves)
        if (!c.is_closed)
            ++end_pairs[{std::min(c.vertices.front(), c.vertices.back()),
                         std::max(c.vertices.front(), c.vertices.back())}];
    // Curves of a patch that keeps its background triangles keep every background point.
    std::vector<std::uint8_t> curve_full(features.curves.size(), 0);
    for (std::size_t p = 0; p < features.patches.size(); ++p)
        if (retry.copy(p))
            for (const auto& loop : features.patches[p].loops)
                for (const auto& use : loop) curve_full[std::size_t(use.curve)] = 1;
    const auto vertex_size = [&retry](std::int32_t v) { return retry.vertex_size(v); };
    std::optional<CurveMerges> merges;
    if (std::find(curve_full.begin(), curve_full.end(), 1) != curve_full.end())
        merges.emplace(bg, features, retry);
    std::vector<DiscreteCurve> curves;
    curves.reserve(features.curves.size());
    for (const auto& c : features.curves) {
        const std::int32_t a = c.vertices.front(), b = c.vertices.back();
        const int min_segments = min_segments_of(c, end_pairs);
        DiscreteCurve d =
            curve_full[curves.size()]
                ? discretise_full(bg, c, features.edges, vertex_size, min_segments, *merges)
                : discretise(bg, c, vertex_size, features.edges, min_segments);
        d.ids.resize(d.points.size());
        for (std::size_t k = 0; k < d.points.size(); ++k) {
            const bool first = k == 0, last = k + 1 == d.points.size();
            if (!c.is_closed && (first || last)) {
                d.ids[k] = corner_id.at(first ? a : b);
            } else if (c.is_closed && last) {
                d.ids[k] = d.ids[0];
            } else {
                d.ids[k] = out.add_vertex(d.points[k]);
                vertex_face.push_back(d.faces[k]);
            }
        }
        curves.push_back(std::move(d));
    }
    return curves;
}

PatchLoops patch_loops(const Features& features, const std::vector<DiscreteCurve>& curves,
                       const core::SurfaceNetwork& out) {
    const std::size_t np = features.patches.size();
    PatchLoops result;
    result.ids.resize(np);
    result.bg.resize(np);
    result.loops.resize(np);
    result.merged.resize(np);
    for (std::size_t p = 0; p < np; ++p) {
        for (const auto& loop : features.patches[p].loops) {
            PatchLoop pl;
            for (const auto& use : loop) {
                const auto& merged = curves[std::size_t(use.curve)].merged;
                result.merged[p].insert(result.merged[p].end(), merged.begin(), merged.end());
                const auto& ids = curves[std::size_t(use.curve)].ids;
                const std::size_t m = ids.size();
                for (std::size_t k = 0; k + 1 < m; ++k) {
                    const std::size_t at = use.forward ? k : m - 1 - k;
                    const std::int32_t id = ids[at];
                    result.ids[p].push_back(id);
                    result.bg[p].push_back(curves[std::size_t(use.curve)].bg_vertex[at]);
                    pl.points.push_back(out.point(id));
                }
            }
            result.loops[p].push_back(std::move(pl));
        }
    }
    return result;
}

std::size_t patches_with_repeated_loop_points(const PatchLoops& loops) {
    std::size_t repeated = 0;
    for (const auto& patch_ids : loops.ids) {
        std::vector<std::int32_t> ids = patch_ids;
        std::sort(ids.begin(), ids.end());
        if (std::adjacent_find(ids.begin(), ids.end()) != ids.end()) ++repeated;
    }
    return repeated;
}

// Valid and exactly on the background; the smoothing and flips after the front improve its
// shape like any other patch's.
PatchMesh copy_background_patch(const core::SurfaceNetwork& bg, const Patch& patch,
                                const std::vector<std::int32_t>& loop_bg,
                                const std::vector<std::array<std::int32_t, 2>>& merged) {
    PatchMesh mesh;
    std::unordered_map<std::int32_t, std::int32_t> into(merged.size());
    for (const auto& [from, to] : merged) into.emplace(from, to);
    std::unordered_map<std::int32_t, std::int32_t> id;
    for (const std::int32_t v : loop_bg) {
        FM_CHECK(v >= 0);
        id.emplace(v, static_cast<std::int32_t>(
                          mesh.points.size()));  // a repeated point keeps its first id
        mesh.points.push_back(bg.point(v));
        mesh.point_face.push_back(patch.faces.front());
    }
    for (const std::int32_t f : patch.faces) {
        std::array<std::int32_t, 3> t{};
        for (int k = 0; k < 3; ++k) {
            std::int32_t v = bg.faces[std::size_t(f)][std::size_t(k)];
            if (const auto m = into.find(v); m != into.end()) v = m->second;
            const auto [it, fresh] = id.emplace(v, static_cast<std::int32_t>(mesh.points.size()));
            if (fresh) {
                mesh.points.push_back(bg.point(v));
                mesh.point_face.push_back(f);
            }
            t[std::size_t(k)] = it->second;
        }
        if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) continue;  // merged away
        mesh.faces.push_back(t);
    }
    return mesh;
}

}  // namespace frontmesh::surface::remesh_detail
