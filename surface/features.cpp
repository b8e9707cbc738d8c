#include "surface/features.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>

#include "pipeline/core/error.h"

namespace frontmesh::surface {

EdgeTable edge_table(const core::SurfaceNetwork& surface) {
    struct HalfEdge {
        std::int64_t key;
        std::int32_t slot;  // 3 * face + local edge
    };
    const std::size_t m = surface.face_count();
    std::vector<HalfEdge> half(3 * m);
    const std::int64_t n = static_cast<std::int64_t>(surface.vertex_count()) + 1;
    for (std::size_t f = 0; f < m; ++f) {
        const auto& t = surface.faces[f];
        for (int i = 0; i < 3; ++i) {
            const std::int64_t a = t[i], b = t[(i + 1) % 3];
            half[3 * f + i] = {std::min(a, b) * n + std::max(a, b),
                               static_cast<std::int32_t>(3 * f + i)};
        }
    }
    std::sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
        return x.key != y.key ? x.key < y.key : x.slot < y.slot;
    });
    EdgeTable table;
    table.face_edges.assign(3 * m, -1);
    table.edge_faces.reserve(3 * m);
    table.face_offsets.push_back(0);
    for (std::size_t i = 0; i < half.size();) {
        std::size_t j = i;
        const auto e = static_cast<std::int32_t>(table.vertices.size());
        table.vertices.push_back({static_cast<std::int32_t>(half[i].key / n),
                                  static_cast<std::int32_t>(half[i].key % n)});
        for (; j < half.size() && half[j].key == half[i].key; ++j) {
            table.face_edges[static_cast<std::size_t>(half[j].slot)] = e;
            const std::int32_t f = half[j].slot / 3;
            if (table.edge_faces.size() == static_cast<std::size_t>(table.face_offsets.back()) ||
                table.edge_faces.back() != f)
                table.edge_faces.push_back(f);
        }
        table.face_offsets.push_back(static_cast<std::int32_t>(table.edge_faces.size()));
        i = j;
    }
    return table;
}

namespace {

Eigen::Vector3d face_normal(const core::SurfaceNetwork& s, std::int32_t f) {
    const auto& t = s.faces[static_cast<std::size_t>(f)];
    const Eigen::Vector3d n = (s.point(t[1]) - s.point(t[0])).cross(s.point(t[2]) - s.point(t[0]));
    const double len = n.norm();
    return len > 0.0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
}

std::string where(const core::SurfaceNetwork& s, std::int32_t v) {
    std::ostringstream out;
    const auto p = s.point(v);
    out << "vertex " << v << " at (" << p.x() << ", " << p.y() << ", " << p.z() << ") mm";
    return out.str();
}

// Local index of the directed edge a -> b in face t, or -1.
int directed_edge(const std::array<std::int32_t, 3>& t, std::int32_t a, std::int32_t b) {
    for (int i = 0; i < 3; ++i)
        if (t[i] == a && t[(i + 1) % 3] == b) return i;
    return -1;
}

// Step 1: junction edges (region pairs differ, other than two faces, or faces of one pair
// using the edge in the same direction) and, with a feature angle, sharp edges. Returns the
// junction flag per edge; sets out.is_feature_edge, out.junction_edges, out.sharp_edges.
std::vector<std::uint8_t> mark_feature_edges(const core::SurfaceNetwork& bg,
                                             double feature_angle_deg,
                                             const std::vector<std::int32_t>& face_part,
                                             Features& out) {
    const EdgeTable& et = out.edges;
    const std::size_t ne = et.edge_count();
    const bool use_angle = feature_angle_deg > 0.0;
    const double cos_feature = std::cos(feature_angle_deg * std::numbers::pi / 180.0);
    auto same_pair = [&](std::int32_t f, std::int32_t g) {
        return bg.region_in[std::size_t(f)] == bg.region_in[std::size_t(g)] &&
               bg.region_out[std::size_t(f)] == bg.region_out[std::size_t(g)] &&
               (face_part.empty() || face_part[std::size_t(f)] == face_part[std::size_t(g)]);
    };
    out.is_feature_edge.assign(ne, 0);
    std::vector<std::uint8_t> is_junction(ne, 0);
    for (std::size_t e = 0; e < ne; ++e) {
        const auto* fs = &et.edge_faces[std::size_t(et.face_offsets[e])];
        const auto k = et.face_count(static_cast<std::int32_t>(e));
        if (k != 2 || !same_pair(fs[0], fs[1])) {
            is_junction[e] = 1;
            ++out.junction_edges;
            continue;
        }
        // Two faces of one pair must use the edge in opposite directions.
        const auto [a, b] = et.vertices[e];
        const bool d0 = directed_edge(bg.faces[std::size_t(fs[0])], a, b) >= 0;
        const bool d1 = directed_edge(bg.faces[std::size_t(fs[1])], a, b) >= 0;
        if (d0 == d1) {
            is_junction[e] = 1;
            ++out.junction_edges;
            continue;
        }
        if (use_angle && face_normal(bg, fs[0]).dot(face_normal(bg, fs[1])) < cos_feature) {
            out.is_feature_edge[e] = 1;
            ++out.sharp_edges;
        }
    }
    for (std::size_t e = 0; e < ne; ++e)
        if (is_junction[e]) out.is_feature_edge[e] = 1;
    return is_junction;
}

// Step 2: patches are faces connected across non-feature edges, numbered by smallest face.
void grow_patches(const core::SurfaceNetwork& bg, Features& out) {
    const EdgeTable& et = out.edges;
    const std::size_t m = bg.face_count();
    out.face_patch.assign(m, -1);
    std::vector<std::int32_t> stack;
    for (std::size_t f0 = 0; f0 < m; ++f0) {
        if (out.face_patch[f0] >= 0) continue;
        const auto p = static_cast<std::int32_t>(out.patches.size());
        Patch patch;
        patch.region_in = bg.region_in[f0];
        patch.region_out = bg.region_out[f0];
        out.face_patch[f0] = p;
        stack.assign(1, static_cast<std::int32_t>(f0));
        while (!stack.empty()) {
            const std::int32_t f = stack.back();
            stack.pop_back();
            patch.faces.push_back(f);
            for (int i = 0; i < 3; ++i) {
                const std::int32_t e = et.edge_of(f, i);
                if (out.is_feature_edge[std::size_t(e)]) continue;
                for (auto k = et.face_offsets[std::size_t(e)];
                     k < et.face_offsets[std::size_t(e) + 1]; ++k) {
                    const std::int32_t g = et.edge_faces[std::size_t(k)];
                    if (out.face_patch[std::size_t(g)] < 0) {
                        out.face_patch[std::size_t(g)] = p;
                        stack.push_back(g);
                    }
                }
            }
        }
        std::sort(patch.faces.begin(), patch.faces.end());
        out.patches.push_back(std::move(patch));
    }
}

// Sharp edges with the same patch on both sides separate nothing: drop them.
void drop_inner_sharp_edges(const std::vector<std::uint8_t>& is_junction, Features& out) {
    const EdgeTable& et = out.edges;
    for (std::size_t e = 0; e < et.edge_count(); ++e) {
        if (!out.is_feature_edge[e] || is_junction[e]) continue;
        const auto* fs = &et.edge_faces[std::size_t(et.face_offsets[e])];
        if (out.face_patch[std::size_t(fs[0])] == out.face_patch[std::size_t(fs[1])]) {
            out.is_feature_edge[e] = 0;
            --out.sharp_edges;
        }
    }
}

// The feature edges at each vertex (CSR, edges in increasing order per vertex).
struct FeatureStar {
    std::vector<std::int32_t> offsets;  // size vertices + 1
    std::vector<std::int32_t> edges;
};

FeatureStar feature_star(const core::SurfaceNetwork& bg, const Features& out) {
    const EdgeTable& et = out.edges;
    const std::size_t nv = bg.vertex_count();
    const std::size_t ne = et.edge_count();
    FeatureStar star;
    star.offsets.assign(nv + 1, 0);
    for (std::size_t e = 0; e < ne; ++e) {
        if (!out.is_feature_edge[e]) continue;
        ++star.offsets[std::size_t(et.vertices[e][0]) + 1];
        ++star.offsets[std::size_t(et.vertices[e][1]) + 1];
    }
    for (std::size_t v = 0; v < nv; ++v) star.offsets[v + 1] += star.offsets[v];
    star.edges.resize(static_cast<std::size_t>(star.offsets[nv]));
    std::vector<std::int32_t> fill(star.offsets.begin(), star.offsets.end() - 1);
    for (std::size_t e = 0; e < ne; ++e) {
        if (!out.is_feature_edge[e]) continue;
        for (int i = 0; i < 2; ++i)
            star.edges[std::size_t(fill[std::size_t(et.vertices[e][i])]++)] =
                static_cast<std::int32_t>(e);
    }
    return star;
}

// Step 3: corners are curve vertices of feature valence != 2 or, with a feature angle, where
// the curve turns by more than it. Returns the corner flag per vertex; fills out.corners.
std::vector<std::uint8_t> find_corners(const core::SurfaceNetwork& bg, double feature_angle_deg,
                                       const FeatureStar& star, Features& out) {
    const EdgeTable& et = out.edges;
    const std::size_t nv = bg.vertex_count();
    const bool use_angle = feature_angle_deg > 0.0;
    const double cos_feature = std::cos(feature_angle_deg * std::numbers::pi / 180.0);
    std::vector<std::uint8_t> is_corner(nv, 0);
    for (std::size_t v = 0; v < nv; ++v) {
        const int valence = star.offsets[v + 1] - star.offsets[v];
        if (valence == 0) continue;
        bool corner = valence != 2;
        if (!corner && use_angle) {
            const auto& e0 = et.vertices[std::size_t(star.edges[std::size_t(star.offsets[v])])];
            const auto& e1 = et.vertices[std::size_t(star.edges[std::size_t(star.offsets[v]) + 1])];
            const auto vi = static_cast<std::int32_t>(v);
            const std::int32_t a = e0[0] == vi ? e0[1] : e0[0];
            const std::int32_t b = e1[0] == vi ? e1[1] : e1[0];
            const Eigen::Vector3d u = (bg.point(vi) - bg.point(a)).normalized();
            const Eigen::Vector3d w = (bg.point(b) - bg.point(vi)).normalized();
            corner = u.dot(w) < cos_feature;  // turning angle above the feature angle
        }
        if (corner) {
            is_corner[v] = 1;
            out.corners.push_back(static_cast<std::int32_t>(v));
        }
    }
    return is_corner;
}

// Where each feature edge lies on the curves: its curve and the position of its first
// vertex along that curve.
struct CurvePlaces {
    std::vector<std::int32_t> curve, position;  // per edge, -1 off the curves
};

// Step 4: curves walk from corners along unvisited feature edges; what remains are loops.
CurvePlaces trace_curves(const core::SurfaceNetwork& bg, const FeatureStar& star,
                         const std::vector<std::uint8_t>& is_corner, Features& out) {
    const EdgeTable& et = out.edges;
    const std::size_t ne = et.edge_count();
    CurvePlaces at;
    at.curve.assign(ne, -1);
    at.position.assign(ne, -1);
    auto walk = [&](std::int32_t start, std::int32_t first_edge) {
        FeatureCurve curve;
        const auto c = static_cast<std::int32_t>(out.curves.size());
        curve.vertices.push_back(start);
        std::int32_t v = start, e = first_edge;
        while (true) {
            at.curve[std::size_t(e)] = c;
            at.position[std::size_t(e)] = static_cast<std::int32_t>(curve.vertices.size()) - 1;
            const auto& ev = et.vertices[std::size_t(e)];
            v = ev[0] == v ? ev[1] : ev[0];
            curve.vertices.push_back(v);
            if (is_corner[std::size_t(v)] || v == start) break;
            std::int32_t next = -1;
            for (auto k = star.offsets[std::size_t(v)]; k < star.offsets[std::size_t(v) + 1]; ++k) {
                const std::int32_t g = star.edges[std::size_t(k)];
                if (g != e && at.curve[std::size_t(g)] < 0) next = g;
            }
            if (next < 0) FM_THROW(GeometryError, "feature curve breaks off at " + where(bg, v));
            e = next;
        }
        curve.is_closed = !is_corner[std::size_t(start)];
        out.curves.push_back(std::move(curve));
    };
    for (const std::int32_t v : out.corners)
        for (auto k = star.offsets[std::size_t(v)]; k < star.offsets[std::size_t(v) + 1]; ++k)
            if (at.curve[std::size_t(star.edges[std::size_t(k)])] < 0)
                walk(v, star.edges[std::size_t(k)]);
    for (std::size_t e = 0; e < ne; ++e)
        if (out.is_feature_edge[e] && at.curve[e] < 0)
            walk(et.vertices[e][0], static_cast<std::int32_t>(e));
    return at;
}

// The boundary half-edge (slot 3 f + i) after `slot` around patch `pi`: turn around its end
// vertex through the patch's faces until a feature edge is reached.
std::int32_t next_boundary_slot(const core::SurfaceNetwork& bg, const Features& out,
                                const Patch& patch, std::int32_t pi, std::int32_t slot) {
    const EdgeTable& et = out.edges;
    const std::size_t m = bg.face_count();
    std::int32_t f = slot / 3;
    int i = slot % 3;
    const std::int32_t b = bg.faces[std::size_t(f)][std::size_t((i + 1) % 3)];
    for (std::size_t guard = 0; guard <= m; ++guard) {
        const int j = (i + 1) % 3;  // edge b -> c of face f
        const std::int32_t e = et.edge_of(f, j);
        if (out.is_feature_edge[std::size_t(e)]) return 3 * f + j;
        const std::int32_t c = bg.faces[std::size_t(f)][std::size_t((j + 1) % 3)];
        std::int32_t g = -1;
        for (auto k = et.face_offsets[std::size_t(e)]; k < et.face_offsets[std::size_t(e) + 1]; ++k)
            if (et.edge_faces[std::size_t(k)] != f) g = et.edge_faces[std::size_t(k)];
        if (g < 0 || out.face_patch[std::size_t(g)] != pi) break;
        f = g;
        i = directed_edge(bg.faces[std::size_t(g)], c, b);
        if (i < 0) break;
    }
    FM_THROW(GeometryError, "region " + std::to_string(patch.region_in) +
                                ": patch boundary cannot be followed at " + where(bg, b));
}

// One closed loop of boundary slots cut into curve uses, starting where a use starts.
std::vector<CurveUse> curve_uses(const core::SurfaceNetwork& bg, const Features& out,
                                 const CurvePlaces& at, const std::vector<std::int32_t>& loop) {
    const EdgeTable& et = out.edges;
    auto use_of = [&](std::int32_t slot) {
        const std::int32_t e = et.edge_of(slot / 3, slot % 3);
        const std::int32_t c = at.curve[std::size_t(e)];
        const std::int32_t a = bg.faces[std::size_t(slot / 3)][std::size_t(slot % 3)];
        const auto& cv = out.curves[std::size_t(c)].vertices;
        const std::int32_t pos = at.position[std::size_t(e)];
        const bool forward = cv[std::size_t(pos)] == a;
        const bool starts = forward ? pos == 0 : pos + 2 == std::int32_t(cv.size());
        return std::make_tuple(c, forward, starts);
    };
    std::size_t first = 0;
    bool found = false;
    for (std::size_t k = 0; k < loop.size() && !found; ++k)
        if (std::get<2>(use_of(loop[k]))) {
            first = k;
            found = true;
        }
    std::vector<CurveUse> uses;
    if (!found) {
        // One closed curve without corner.
        const auto [c, forward, starts] = use_of(loop.front());
        if (!out.curves[std::size_t(c)].is_closed)
            FM_THROW(InternalError, "patch loop without a curve start");
        uses.push_back({c, forward});
    } else {
        for (std::size_t k = 0; k < loop.size(); ++k) {
            const auto [c, forward, starts] = use_of(loop[(first + k) % loop.size()]);
            if (starts) uses.push_back({c, forward});
        }
    }
    return uses;
}

// Step 5: the boundary loops of patch p, from its directed boundary edges (patch to the
// left), each next one found by turning around the end vertex through the patch's faces.
void trace_patch_loops(const core::SurfaceNetwork& bg, const CurvePlaces& at, std::size_t p,
                       Features& out) {
    const EdgeTable& et = out.edges;
    Patch& patch = out.patches[p];
    const auto pi = static_cast<std::int32_t>(p);
    // Boundary half-edges as slots 3 * f + i, in increasing order.
    std::vector<std::int32_t> slots;
    for (const std::int32_t f : patch.faces)
        for (int i = 0; i < 3; ++i)
            if (out.is_feature_edge[std::size_t(et.edge_of(f, i))]) slots.push_back(3 * f + i);
    if (slots.empty()) return;
    std::vector<std::uint8_t> used(slots.size(), 0);
    auto slot_index = [&](std::int32_t slot) {
        const auto it = std::lower_bound(slots.begin(), slots.end(), slot);
        return it != slots.end() && *it == slot ? std::int32_t(it - slots.begin()) : -1;
    };
    for (std::size_t s0 = 0; s0 < slots.size(); ++s0) {
        if (used[s0]) continue;
        std::vector<std::int32_t> loop;  // slots
        std::int32_t s = slots[s0];
        while (true) {
            const std::int32_t idx = slot_index(s);
            if (idx < 0) FM_THROW(InternalError, "patch boundary edge not indexed");
            if (used[std::size_t(idx)]) break;
            used[std::size_t(idx)] = 1;
            loop.push_back(s);
            s = next_boundary_slot(bg, out, patch, pi, s);
        }
        if (s != loop.front())
            FM_THROW(GeometryError,
                     "region " + std::to_string(patch.region_in) +
                         ": patch boundary loop does not close at " +
                         where(bg, bg.faces[std::size_t(s / 3)][std::size_t(s % 3)]));
        patch.loops.push_back(curve_uses(bg, out, at, loop));
    }
}

}  // namespace

// §2: "geometrical features are extracted from the background mesh".
Features find_features(const core::SurfaceNetwork& bg, double feature_angle_deg,
                       core::StageContext& ctx, const std::vector<std::int32_t>& face_part) {
    if (!face_part.empty() && face_part.size() != bg.face_count())
        FM_THROW(InternalError, "find_features: face_part needs one entry per face");
    Features out;
    out.edges = edge_table(bg);
    const std::vector<std::uint8_t> is_junction =
        mark_feature_edges(bg, feature_angle_deg, face_part, out);
    grow_patches(bg, out);
    drop_inner_sharp_edges(is_junction, out);
    const FeatureStar star = feature_star(bg, out);
    const std::vector<std::uint8_t> is_corner = find_corners(bg, feature_angle_deg, star, out);
    const CurvePlaces at = trace_curves(bg, star, is_corner, out);
    for (std::size_t p = 0; p < out.patches.size(); ++p) trace_patch_loops(bg, at, p, out);

    ctx.count("remesh.junction_edges", double(out.junction_edges));
    ctx.count("remesh.sharp_edges", double(out.sharp_edges));
    ctx.count("remesh.corners", double(out.corners.size()));
    ctx.count("remesh.curves", double(out.curves.size()));
    ctx.count("remesh.patches", double(out.patches.size()));
    return out;
}

}  // namespace frontmesh::surface
