// Curves and loops of the remesh stage (paper §2: "by specifying node distribution on the
// features, the local mesh density can be easily controlled"): each feature curve is cut by
// the size field (with the retry policy's multipliers) into points shared by the patches it
// bounds, and the patches' boundary loops are read off those points.

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

#include "pipeline/core/error.h"
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

// The curve at full resolution: every polyline vertex is a point (the boundary of a patch
// copied from the background).
DiscreteCurve discretise_full(const core::SurfaceNetwork& bg, const FeatureCurve& curve,
                              const EdgeTable& edges) {
    const auto& cv = curve.vertices;
    DiscreteCurve out;
    double arc = 0.0;
    for (std::size_t i = 0; i < cv.size(); ++i) {
        if (i > 0) arc += (bg.point(cv[i]) - bg.point(cv[i - 1])).norm();
        out.points.push_back(bg.point(cv[i]));
        out.s.push_back(arc);
        out.faces.push_back(curve_segment_face(edges, cv, std::min(i, cv.size() - 2)));
        out.bg_vertex.push_back(cv[i]);
    }
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
    std::vector<DiscreteCurve> curves;
    curves.reserve(features.curves.size());
    for (const auto& c : features.curves) {
        const std::int32_t a = c.vertices.front(), b = c.vertices.back();
        DiscreteCurve d = curve_full[curves.size()] ? discretise_full(bg, c, features.edges)
                                                    : discretise(bg, c, vertex_size, features.edges,
                                                                 min_segments_of(c, end_pairs));
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
    for (std::size_t p = 0; p < np; ++p) {
        for (const auto& loop : features.patches[p].loops) {
            PatchLoop pl;
            for (const auto& use : loop) {
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
                                const std::vector<std::int32_t>& loop_bg) {
    PatchMesh mesh;
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
            const std::int32_t v = bg.faces[std::size_t(f)][std::size_t(k)];
            const auto [it, fresh] = id.emplace(v, static_cast<std::int32_t>(mesh.points.size()));
            if (fresh) {
                mesh.points.push_back(bg.point(v));
                mesh.point_face.push_back(f);
            }
            t[std::size_t(k)] = it->second;
        }
        mesh.faces.push_back(t);
    }
    return mesh;
}

}  // namespace frontmesh::surface::remesh_detail
