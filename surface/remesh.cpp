#include "surface/remesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "pipeline/core/self_intersection.h"
#include "surface/features.h"
#include "surface/front_triangulate.h"
#include "surface/size_field.h"
#include "surface/surface_smoothing.h"

namespace frontmesh::surface {

namespace {

// Wall time of sub-steps, reported as counters (never used to decide anything).
class StepClock {
public:
    explicit StepClock(core::StageContext& ctx) : ctx_(ctx), last_(now()) {}
    void lap(const std::string& step) {
        const auto t = now();
        ctx_.count("remesh.time_" + step + "_s", std::chrono::duration<double>(t - last_).count());
        last_ = t;
    }

private:
    static std::chrono::steady_clock::time_point now() { return std::chrono::steady_clock::now(); }
    core::StageContext& ctx_;
    std::chrono::steady_clock::time_point last_;
};

std::string point_text(const Eigen::Vector3d& p) {
    std::ostringstream out;
    out << "(" << p.x() << ", " << p.y() << ", " << p.z() << ") mm";
    return out.str();
}

// One feature curve cut into segments whose lengths follow the size field (§2: "specifying
// node distribution on the features"): arc length integrated with density 1/h.
struct DiscreteCurve {
    std::vector<std::int32_t> ids;        // output vertex ids along the curve
    std::vector<Eigen::Vector3d> points;  // their positions
    std::vector<double> s;                // arc length on the background polyline, mm
    std::vector<std::int32_t> faces;      // a background face at each point
    std::vector<std::int32_t> bg_vertex;  // the background vertex at each point, or -1
};

// A background face next to segment (cv[i], cv[i + 1]) of a curve polyline, for size queries.
std::int32_t curve_segment_face(const EdgeTable& edges, const std::vector<std::int32_t>& cv, std::size_t i) {
    const std::int32_t a = std::min(cv[i], cv[i + 1]), b = std::max(cv[i], cv[i + 1]);
    const auto it = std::lower_bound(edges.vertices.begin(), edges.vertices.end(), std::array<std::int32_t, 2>{a, b});
    FM_CHECK(it != edges.vertices.end() && (*it)[0] == a && (*it)[1] == b);
    return edges.edge_faces[std::size_t(edges.face_offsets[std::size_t(it - edges.vertices.begin())])];
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
        integral[i] = integral[i - 1] +
                      0.5 * len * (1.0 / vertex_size(cv[i - 1]) + 1.0 / vertex_size(cv[i]));
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
// copied from the background, below).
DiscreteCurve discretise_full(const core::SurfaceNetwork& bg, const FeatureCurve& curve, const EdgeTable& edges) {
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

// The last resort for a patch whose front stalls again and again (a fold or pinch of the
// background the front cannot follow at any size): the patch's own background triangles,
// its boundary at full resolution. Valid and exactly on the background; the smoothing and
// flips after the front improve its shape like any other patch's. `loop_bg`: the background
// vertex of each loop point, in loop order (loop points come first, as from the front).
PatchMesh copy_background_patch(const core::SurfaceNetwork& bg, const Patch& patch,
                                const std::vector<std::int32_t>& loop_bg) {
    PatchMesh mesh;
    std::unordered_map<std::int32_t, std::int32_t> id;
    for (const std::int32_t v : loop_bg) {
        FM_CHECK(v >= 0);
        id.emplace(v, static_cast<std::int32_t>(mesh.points.size()));  // a repeated point keeps its first id
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

// Edges of `region`'s boundary in `s` with other than two of its faces (open or
// non-manifold), in edge order.
std::vector<std::int32_t> edges_not_two_faces(const core::SurfaceNetwork& s, const EdgeTable& et,
                                              core::Label region) {
    std::vector<std::int32_t> bad;
    for (std::size_t e = 0; e < et.edge_count(); ++e) {
        int uses = 0;
        for (auto k = et.face_offsets[e]; k < et.face_offsets[e + 1]; ++k) {
            const auto f = std::size_t(et.edge_faces[std::size_t(k)]);
            uses += s.region_in[f] == region || s.region_out[f] == region;
        }
        if (uses != 0 && uses != 2) bad.push_back(static_cast<std::int32_t>(e));
    }
    return bad;
}

Eigen::Vector3d edge_midpoint(const core::SurfaceNetwork& s, const EdgeTable& et, std::int32_t e) {
    const auto& v = et.vertices[std::size_t(e)];
    return 0.5 * (s.point(v[0]) + s.point(v[1]));
}

// Two patches that both joined the same two curve points by an inner edge (a thin lens
// between two curves) would make that edge non-manifold: the edge is flipped inside the
// later patch (the other diagonal of its two faces there) when both new faces keep the
// orientation of the old ones and the diagonal is not an edge yet. Returns the flips made.
std::size_t flip_shared_inner_edges(core::SurfaceNetwork& out, const std::vector<std::int32_t>& face_patch,
                                     std::size_t curve_points) {
    std::size_t flips = 0;
    for (int sweep = 0; sweep < 3; ++sweep) {
        const EdgeTable et = edge_table(out);
        std::set<std::pair<std::int32_t, std::int32_t>> edges;
        for (const auto& e : et.vertices) edges.insert({e[0], e[1]});
        std::vector<std::uint8_t> touched(out.face_count(), 0);
        std::size_t made = 0;
        for (std::size_t e = 0; e < et.edge_count(); ++e) {
            const auto [x, y] = et.vertices[e];
            if (std::size_t(x) >= curve_points || std::size_t(y) >= curve_points) continue;
            const auto b = et.face_offsets[e], n = et.face_offsets[e + 1] - b;
            if (n <= 2) continue;
            // The faces of each patch on this edge; flip in the last patch holding two.
            std::map<std::int32_t, std::vector<std::int32_t>> by_patch;
            for (auto k = b; k < b + n; ++k) {
                const std::int32_t f = et.edge_faces[std::size_t(k)];
                by_patch[face_patch[std::size_t(f)]].push_back(f);
            }
            for (auto it = by_patch.rbegin(); it != by_patch.rend(); ++it) {
                if (it->second.size() != 2) continue;
                std::int32_t f = it->second[0], g = it->second[1];
                if (touched[std::size_t(f)] || touched[std::size_t(g)]) continue;
                // Orient so that f holds x -> y.
                auto holds = [&](std::int32_t face) {
                    const auto& t = out.faces[std::size_t(face)];
                    for (int k = 0; k < 3; ++k)
                        if (t[std::size_t(k)] == x && t[std::size_t((k + 1) % 3)] == y) return k;
                    return -1;
                };
                if (holds(f) < 0) std::swap(f, g);
                const int i = holds(f);
                if (i < 0) continue;
                const auto tf = out.faces[std::size_t(f)], tg = out.faces[std::size_t(g)];
                const std::int32_t c = tf[std::size_t((i + 2) % 3)];
                std::int32_t d = -1;
                for (int j = 0; j < 3; ++j)
                    if (tg[std::size_t(j)] == y && tg[std::size_t((j + 1) % 3)] == x) d = tg[std::size_t((j + 2) % 3)];
                if (d < 0 || c == d || edges.count({std::min(c, d), std::max(c, d)})) continue;
                const std::array<std::int32_t, 3> nf{c, x, d}, ng{d, y, c};
                auto normal = [&](const std::array<std::int32_t, 3>& t) {
                    return Eigen::Vector3d((out.point(t[1]) - out.point(t[0])).cross(out.point(t[2]) - out.point(t[0])));
                };
                const Eigen::Vector3d before = normal(tf) + normal(tg);
                if (!(normal(nf).dot(before) > 0.0 && normal(ng).dot(before) > 0.0)) continue;
                out.faces[std::size_t(f)] = nf;
                out.faces[std::size_t(g)] = ng;
                edges.insert({std::min(c, d), std::max(c, d)});
                touched[std::size_t(f)] = touched[std::size_t(g)] = 1;
                ++made;
                break;
            }
        }
        flips += made;
        if (made == 0) break;
    }
    return flips;
}

}  // namespace

double default_edge_length(const core::SurfaceNetwork& background) {
    return 2.0 * mean_edge_length(background);
}

RemeshResult remesh(const core::SurfaceNetwork& bg, const RemeshParams& params,
                    core::StageContext& ctx) {
    validate(params);
    if (bg.face_count() == 0) FM_THROW(InputError, "remesh: the background surface is empty");
    for (const auto& c : core::check_region_boundaries(bg))
        if (!c.is_closed())
            FM_THROW(InputError, "remesh: region " + std::to_string(c.region) +
                                     " of the background is not closed (run repair first)");

    // 1. Features.
    StepClock clock(ctx);
    ctx.progress(0.0, "features");
    const Features features = find_features(bg, params.feature_angle_deg, ctx);
    clock.lap("features");

    // 2. Size field.
    ctx.progress(0.05, "size field");
    SizeFieldParams sp;
    sp.edge_length = params.edge_length > 0.0 ? params.edge_length : default_edge_length(bg);
    sp.gradation = params.gradation;
    sp.min_edge_length = params.min_edge_length;
    sp.max_edge_length = params.max_edge_length;
    sp.curvature_angle_deg = params.curvature_angle_deg;
    sp.thickness_layers = params.thickness_layers;
    sp.label_edge_length = params.label_edge_length;
    const SizeField size = build_size_field(bg, sp, ctx);
    clock.lap("size_field");
    ctx.count("remesh.edge_length_mm", sp.edge_length);
    ctx.info("remesh: h = " + std::to_string(sp.edge_length) + " mm, " +
             std::to_string(features.patches.size()) + " patches, " +
             std::to_string(features.curves.size()) + " curves");

    // Steps 3 to 7 run again, with the size halved around each crossing, when faces of the
    // result intersect (at most kRounds times).
    constexpr int kRounds = 10;
    // Stalls per patch over the rounds; a patch whose front stalls twice is copied from the
    // background (copy_background_patch) from then on.
    std::vector<int> patch_stalls(features.patches.size(), 0), patch_crossings(features.patches.size(), 0);
    std::vector<std::uint8_t> copy_patch(features.patches.size(), 0);
    std::vector<std::pair<Eigen::Vector3d, double>> shrink_sites;  // centre, radius (mm)
    // A patch whose loops, copy state and size field (no new shrink site within reach of its
    // bounding box) are those of a round it was meshed in keeps that mesh: the front is
    // deterministic, so the result is the same, and a round costs only the patches it changes.
    const std::size_t np = features.patches.size();
    std::vector<BackgroundPatch> patches;
    patches.reserve(np);
    for (const auto& p : features.patches) patches.emplace_back(bg, p.faces, false);
    std::vector<core::AdtBox> patch_box(np);
    for (std::size_t p = 0; p < np; ++p) {
        const auto& fv = bg.faces[std::size_t(features.patches[p].faces.front())];
        patch_box[p] = core::AdtBox::of_point(bg.point(fv[0]));
        for (const std::int32_t f : features.patches[p].faces)
            for (const std::int32_t v : bg.faces[std::size_t(f)]) patch_box[p].extend(bg.point(v));
    }
    std::vector<PatchMesh> meshes(np);
    std::vector<core::StageContext> contexts(np);
    // Size scale per background face and vertex (remesh.max_volume_change_percent), and the
    // patches whose scale changed since they were meshed.
    std::vector<double> face_scale(bg.face_count(), 1.0), vertex_scale(bg.vertex_count(), 1.0);
    std::vector<std::uint8_t> patch_rescaled(np, 0);
    std::vector<std::vector<PatchLoop>> meshed_loops(np);
    std::vector<std::uint8_t> meshed(np, 0), meshed_copy(np, 0);
    std::size_t sites_seen = 0;
    const auto scale_at = [&shrink_sites](const Eigen::Vector3d& x) {
        double scale = 1.0;
        for (const auto& [c, r] : shrink_sites) {
            const double d = (x - c).norm();
            if (d < 2.0 * r) scale *= d <= r ? 0.5 : 0.5 + 0.5 * (d - r) / r;
        }
        return std::max(scale, 0.125);
    };
    const auto vertex_size = [&](std::int32_t v) {
        return size.at_vertex(v) * scale_at(bg.point(v)) * vertex_scale[std::size_t(v)];
    };
    core::SurfaceNetwork out;
    SurfaceConstraints constraints;
    std::size_t curve_points = 0;
    // Counters summed over patches and passes: those of the last round only are reported.
    std::map<std::string, double> round_sums;
    for (int round = 0; round < kRounds; ++round) {
        ctx.count("remesh.rounds", double(round + 1));
        round_sums.clear();
        // 3. Curves first, shared by every patch they bound. Output vertices: corners, then each
        // curve's other points.
        ctx.progress(0.15, "curves");
        out = core::SurfaceNetwork();
        std::vector<std::int32_t> vertex_face;
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
        std::vector<DiscreteCurve> curves;
        curves.reserve(features.curves.size());
        std::vector<std::uint8_t> curve_full(features.curves.size(), 0);
        for (std::size_t p = 0; p < features.patches.size(); ++p)
            if (copy_patch[p])
                for (const auto& loop : features.patches[p].loops)
                    for (const auto& use : loop) curve_full[std::size_t(use.curve)] = 1;
        for (const auto& c : features.curves) {
            const std::int32_t a = c.vertices.front(), b = c.vertices.back();
            int min_segments = 1;
            if (c.is_closed || a == b) min_segments = 3;
            else if (end_pairs[{std::min(a, b), std::max(a, b)}] > 1) min_segments = 2;
            DiscreteCurve d = curve_full[curves.size()] ? discretise_full(bg, c, features.edges)
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
        curve_points = out.vertex_count();
        ctx.count("remesh.curve_points", double(curve_points));

        // 4. Patches: background patch, loops from the shared curve points, advancing front.
        ctx.progress(0.2, "advancing front");
        std::vector<std::vector<std::int32_t>> loop_ids(np), loop_bg(np);
        std::vector<std::vector<PatchLoop>> loops(np);
        for (std::size_t p = 0; p < np; ++p) {
            for (const auto& loop : features.patches[p].loops) {
                PatchLoop pl;
                for (const auto& use : loop) {
                    const auto& ids = curves[std::size_t(use.curve)].ids;
                    const std::size_t m = ids.size();
                    for (std::size_t k = 0; k + 1 < m; ++k) {
                        const std::size_t at = use.forward ? k : m - 1 - k;
                        const std::int32_t id = ids[at];
                        loop_ids[p].push_back(id);
                        loop_bg[p].push_back(curves[std::size_t(use.curve)].bg_vertex[at]);
                        pl.points.push_back(out.point(id));
                    }
                }
                loops[p].push_back(std::move(pl));
            }
        }
        // Loops that pass a point twice (a patch touching itself at a corner) are legal but the
        // hardest case for the front; counted for diagnosis.
        {
            std::size_t repeated = 0;
            for (std::size_t p = 0; p < np; ++p) {
                std::vector<std::int32_t> ids = loop_ids[p];
                std::sort(ids.begin(), ids.end());
                if (std::adjacent_find(ids.begin(), ids.end()) != ids.end()) ++repeated;
            }
            ctx.count("remesh.patches_with_repeated_loop_points", double(repeated));
        }
        const SizeFunction size_function = [&size, &scale_at, &face_scale](const Eigen::Vector3d& x, std::int32_t face) {
            return size.at(x, face) * scale_at(x) * (face >= 0 ? face_scale[std::size_t(face)] : 1.0);
        };
        FrontParams fp;
        std::vector<std::uint8_t> dirty(np, 0);
        std::size_t remeshed = 0;
        for (std::size_t p = 0; p < np; ++p) {
            bool same = meshed[p] && !patch_rescaled[p] && meshed_copy[p] == copy_patch[p] &&
                        meshed_loops[p].size() == loops[p].size();
            for (std::size_t l = 0; same && l < loops[p].size(); ++l)
                same = meshed_loops[p][l].points == loops[p][l].points;
            for (std::size_t k = sites_seen; same && k < shrink_sites.size(); ++k) {
                const auto& [c, r] = shrink_sites[k];
                double d2 = 0.0;  // squared distance from c to the box
                for (int i = 0; i < 3; ++i) {
                    const double lo = patch_box[p].lo[i], hi = patch_box[p].hi[i];
                    const double t = c[i] < lo ? lo - c[i] : c[i] > hi ? c[i] - hi : 0.0;
                    d2 += t * t;
                }
                same = d2 >= 4.0 * r * r;  // scale_at is 1 beyond 2r
            }
            dirty[p] = !same;
            remeshed += dirty[p];
        }
        sites_seen = shrink_sites.size();
        std::fill(patch_rescaled.begin(), patch_rescaled.end(), 0);
        ctx.count("remesh.patches_meshed_in_last_round", double(remeshed));
        // A patch whose front stalls is recorded (patch order decides which error is
        // reported, so the result does not depend on the threads).
        std::vector<std::optional<FrontStall>> stalls(np);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, np, 1), [&](const auto& range) {
            for (std::size_t p = range.begin(); p != range.end(); ++p) {
                if (!dirty[p]) continue;
                meshed[p] = 0;
                contexts[p] = core::StageContext();
                try {
                    if (copy_patch[p])
                        meshes[p] = copy_background_patch(bg, features.patches[p], loop_bg[p]);
                    else
                        meshes[p] = triangulate_patch(patches[p], loops[p], size_function, fp, contexts[p]);
                    meshed[p] = 1;
                    meshed_copy[p] = copy_patch[p];
                    meshed_loops[p] = loops[p];
                } catch (const FrontStall& e) {
                    stalls[p] = e;
                }
            }
        });
        std::size_t stalled = 0;
        std::string places;
        for (std::size_t p = 0; p < np; ++p) {
            if (!stalls[p]) continue;
            if (++stalled <= 4) places += " " + point_text(stalls[p]->place());
            if (round + 1 >= kRounds) throw *stalls[p];
            if (++patch_stalls[p] >= 2) {
                copy_patch[p] = 1;
                continue;
            }
            const Eigen::Vector3d& x = stalls[p]->place();
            shrink_sites.emplace_back(x, 4.0 * size.at(x, -1));
        }
        if (stalled > 0) {
            ctx.warn("remesh: the front stalled in " + std::to_string(stalled) + " patch(es) (near" + places +
                     "); meshing again with half the size there (a patch stalling twice keeps its background triangles)");
            continue;
        }
        {
            std::size_t copied = 0, copied_faces = 0;
            for (std::size_t p = 0; p < np; ++p)
                if (copy_patch[p]) ++copied, copied_faces += meshes[p].faces.size();
            ctx.count("remesh.patches_copied_from_background", double(copied));
            if (copied > 0)
                ctx.warn("remesh: " + std::to_string(copied) + " patch(es) (" + std::to_string(copied_faces) +
                         " faces) keep their background triangles: the front stalled there twice or faces crossed three times");
        }
        for (std::size_t p = 0; p < np; ++p) {
            for (const auto& [name, value] : contexts[p].counters()) round_sums[name] += value;
            for (const auto& w : contexts[p].warnings()) ctx.warn(w);
        }

        // 5. One network: loop points are the shared curve points, exactly.
        ctx.progress(0.6, "assembly");
        std::vector<std::int32_t> face_patch;
        for (std::size_t p = 0; p < np; ++p) {
            const PatchMesh& mesh = meshes[p];
            const std::size_t nloop = loop_ids[p].size();
            FM_CHECK(mesh.points.size() >= nloop && mesh.point_face.size() == mesh.points.size());
            std::vector<std::int32_t> map(mesh.points.size());
            for (std::size_t k = 0; k < nloop; ++k) {
                map[k] = loop_ids[p][k];
                if (mesh.points[k] != out.point(map[k]))
                    FM_THROW(InternalError, "remesh: patch " + std::to_string(p) +
                                                " moved loop point " + point_text(mesh.points[k]));
            }
            for (std::size_t k = nloop; k < mesh.points.size(); ++k) {
                map[k] = out.add_vertex(mesh.points[k]);
                vertex_face.push_back(mesh.point_face[k]);
            }
            const Patch& patch = features.patches[p];
            for (const auto& t : mesh.faces) {
                out.add_face(map[std::size_t(t[0])], map[std::size_t(t[1])], map[std::size_t(t[2])],
                             patch.region_in, patch.region_out);
                face_patch.push_back(static_cast<std::int32_t>(p));
            }
        }
        ctx.count("remesh.front_faces", double(out.face_count()));
        round_sums["remesh.shared_inner_edges_flipped"] +=
            double(flip_shared_inner_edges(out, face_patch, curve_points));
        clock.lap("front");

        // 6. Angle-based smoothing with projection, curve vertices on their curves, flips.
        ctx.progress(0.7, "smoothing");
        constraints = SurfaceConstraints();
        constraints.face_patch = std::move(face_patch);
        constraints.vertex_face = vertex_face;
        for (std::size_t c = 0; c < curves.size(); ++c) {
            SurfaceCurve sc;
            sc.is_closed = features.curves[c].is_closed;
            for (const auto v : features.curves[c].vertices) sc.polyline.push_back(bg.point(v));
            sc.vertices = curves[c].ids;
            sc.s = curves[c].s;
            constraints.curves.push_back(std::move(sc));
        }
        const std::vector<double> front_xyz = out.xyz;  // positions before smoothing
        if (params.smoothing_iterations > 0) {
            std::vector<const BackgroundPatch*> pointers;
            for (const auto& p : patches) pointers.push_back(&p);
            SmoothingParams smp;
            smp.iterations = params.smoothing_iterations;
            smp.flip_max_dihedral_deg = params.flip_max_dihedral_deg;
            core::StageContext sub;
            smooth_surface(out, pointers, constraints, smp, sub);
            for (const auto& [name, value] : sub.counters()) round_sums[name] += value;
        }

        clock.lap("smoothing");

        // 7. Checks.
        ctx.progress(0.9, "checks");
        const auto checks = core::check_region_boundaries(out);
        bool again = false;
        std::optional<EdgeTable> out_edges;  // built only when a region fails its check
        const auto et_of_out = [&]() -> const EdgeTable& {
            if (!out_edges) out_edges = edge_table(out);
            return *out_edges;
        };
        std::string rescaled;  // regions meshed again finer for their volume
        for (const auto& c : checks) {
            if (!c.is_closed() || !c.is_oriented() || c.nonmanifold_edges > 0) {
                const std::vector<std::int32_t> bad = edges_not_two_faces(out, et_of_out(), c.region);
                if (round + 1 < kRounds) {
                    // Two patches joined the same two curve points by an inner edge (a short
                    // curve between sharp corners): meshed again with finer curves there.
                    for (const std::int32_t e : bad) {
                        const Eigen::Vector3d m = edge_midpoint(out, et_of_out(), e);
                        shrink_sites.emplace_back(m, 2.0 * size.at(m, -1));
                    }
                    ctx.warn("remesh: region " + std::to_string(c.region) +
                             " is not a closed 2-manifold after the front; meshing again with half the size there");
                    again = true;
                    break;
                }
                // Name a place: the first such edge and the patches of its faces.
                std::string place;
                if (!bad.empty()) {
                    const EdgeTable& et = et_of_out();
                    const auto e = std::size_t(bad.front());
                    std::string patches;
                    for (auto k = et.face_offsets[e]; k < et.face_offsets[e + 1]; ++k) {
                        const auto f = std::size_t(et.edge_faces[std::size_t(k)]);
                        if (out.region_in[f] == c.region || out.region_out[f] == c.region)
                            patches += " " + std::to_string(constraints.face_patch[f]);
                    }
                    place = " (e.g. the edge at " + point_text(edge_midpoint(out, et, bad.front())) +
                            ", faces of patches" + patches + ")";
                }
                FM_THROW(GeometryError, "remesh: region " + std::to_string(c.region) + " has " +
                                            std::to_string(c.open_edges) + " open, " +
                                            std::to_string(c.misoriented_edges) + " misoriented, " +
                                            std::to_string(c.nonmanifold_edges) +
                                            " non-manifold edges after remeshing" + place);
            }
            const double before = core::enclosed_volume(bg, c.region);
            const double change = before != 0.0 ? 100.0 * (c.volume - before) / before : 0.0;
            ctx.count("remesh.volume_change_percent.region_" + std::to_string(c.region), change);
            const double limit = params.max_volume_change_percent;
            if (limit > 0.0 && std::abs(change) > limit) {
                if (round + 1 < kRounds) {
                    // Chords lose volume as h^2: scale the sizes of the region's patches by
                    // about sqrt(limit / change), with a margin.
                    const double factor = std::clamp(0.9 * std::sqrt(limit / std::abs(change)), 0.5, 0.9);
                    for (std::size_t p = 0; p < np; ++p) {
                        const Patch& patch = features.patches[p];
                        if (patch.region_in != c.region && patch.region_out != c.region) continue;
                        patch_rescaled[p] = 1;
                        for (const std::int32_t f : patch.faces) face_scale[std::size_t(f)] *= factor;
                    }
                    rescaled += " " + std::to_string(c.region) + " (" + std::to_string(change) + " %)";
                } else {
                    ctx.warn("remesh: region " + std::to_string(c.region) + " changed its volume by " +
                             std::to_string(change) + " %, more than remesh.max_volume_change_percent");
                }
            }
        }
        if (!rescaled.empty()) {
            for (std::size_t f = 0; f < bg.face_count(); ++f)
                for (const std::int32_t v : bg.faces[f])
                    vertex_scale[std::size_t(v)] = std::min(vertex_scale[std::size_t(v)], face_scale[f]);
        }
        if (again) continue;
        if (params.check_self_intersections) {
            // A local fix: vertices of intersecting faces go back to where the front put them
            // (smoothing moved them); a few rounds, then the first remaining pair is an error.
            auto pairs = core::self_intersections(out, 1000);
            ctx.count("remesh.self_intersections_after_smoothing", double(pairs.size()));
            for (int round = 0; round < 3 && !pairs.empty(); ++round) {
                for (const auto& [f, g] : pairs)
                    for (const std::int32_t face : {f, g})
                        for (const auto v : out.faces[std::size_t(face)])
                            for (int k = 0; k < 3; ++k)
                                out.xyz[3 * std::size_t(v) + std::size_t(k)] =
                                    front_xyz[3 * std::size_t(v) + std::size_t(k)];
                pairs = core::self_intersections(out, 1000);
            }
            ctx.count("remesh.self_intersections", double(pairs.size()));
            if (!pairs.empty() && round + 1 < kRounds) {
                // Meshed again with half the size around each crossing (two patches meeting at
                // a sharp angle, or a gap narrower than the smallest size): the finer the
                // triangles, the closer they follow the background, which does not intersect.
                // A patch whose faces still cross after two rounds of finer sizes (two sheets
                // meeting in a cusp along a curve) keeps its background triangles instead.
                std::set<std::int32_t> crossed;
                for (const auto& [f, g] : pairs)
                    for (const std::int32_t face : {f, g}) crossed.insert(constraints.face_patch[std::size_t(face)]);
                for (const std::int32_t q : crossed)
                    if (++patch_crossings[std::size_t(q)] >= 3) copy_patch[std::size_t(q)] = 1;
                for (const auto& [f, g] : pairs)
                    for (const std::int32_t face : {f, g}) {
                        if (copy_patch[std::size_t(constraints.face_patch[std::size_t(face)])]) continue;
                        const auto& t = out.faces[std::size_t(face)];
                        const Eigen::Vector3d c = (out.point(t[0]) + out.point(t[1]) + out.point(t[2])) / 3.0;
                        shrink_sites.emplace_back(c, 2.0 * size.at(c, -1));
                    }
                ctx.warn("remesh: " + std::to_string(pairs.size()) +
                         " pairs of faces intersect after smoothing; meshing again with half the size there");
                continue;
            }
            if (!pairs.empty()) {
                const auto& t = out.faces[std::size_t(pairs[0].first)];
                const Eigen::Vector3d c = (out.point(t[0]) + out.point(t[1]) + out.point(t[2])) / 3.0;
                FM_THROW(GeometryError,
                         "remesh: faces " + std::to_string(pairs[0].first) + " and " +
                             std::to_string(pairs[0].second) + " intersect near " + point_text(c) +
                             " (region " + std::to_string(out.region_in[std::size_t(pairs[0].first)]) +
                             ", patches " +
                             std::to_string(constraints.face_patch[std::size_t(pairs[0].first)]) + " and " +
                             std::to_string(constraints.face_patch[std::size_t(pairs[0].second)]) +
                             "); try a smaller remesh.edge_length there");
            }
        }
        if (!rescaled.empty()) {
            ctx.warn("remesh: regions" + rescaled +
                     " changed their volume more than remesh.max_volume_change_percent; meshing them again finer");
            continue;
        }
        break;
    }
    for (const auto& [name, value] : round_sums) ctx.add(name, value);
    clock.lap("checks");

    RemeshResult result;
    result.target_size.resize(out.vertex_count());
    for (std::size_t v = 0; v < out.vertex_count(); ++v) {
        // Curve points may have slid off their face hint: use the nearest background vertex.
        const std::int32_t face = v < curve_points ? -1 : constraints.vertex_face[v];
        result.target_size[v] = size.at(out.point(static_cast<std::int32_t>(v)), face);
    }
    // Region wedges at junction edges (issue 5): under 12 degrees, no tetrahedron of the
    // region on that edge can reach 12 (the smoothing's wedge pass raises them; reported).
    ctx.count("remesh.region_wedges_below_12_deg", double(thin_region_wedges(out, 12.0).size()));
    // Spike tips (issue 5): a thin three-face cone whose only tetrahedron there is fixed by the
    // surface; those under 10 degrees stay under 10 after refine (the tip pass raises them).
    {
        std::size_t below = 0;
        for (const ForcedTet& tip : forced_tets(out, 20.0)) below += tip.min_dihedral_deg < 10.0;
        ctx.count("remesh.forced_tets_below_10_deg", double(below));
    }
    const SurfaceQuality q = surface_quality(out);
    ctx.count("remesh.vertices", double(out.vertex_count()));
    ctx.count("remesh.faces", double(out.face_count()));
    ctx.count("remesh.min_angle_deg", q.min_angle_deg);
    ctx.count("remesh.mean_eta", q.mean_eta);
    ctx.count("remesh.fraction_min_angle_ge_30", q.fraction_at_least_30_deg);
    ctx.progress(1.0, "done");
    result.surface = std::move(out);
    return result;
}

HausdorffDistance hausdorff_distance(const core::SurfaceNetwork& a, const core::SurfaceNetwork& b) {
    auto one_way = [](const core::SurfaceNetwork& from, const core::SurfaceNetwork& to,
                      double& max_out, double& mean_out) {
        std::vector<std::int32_t> all(to.face_count());
        for (std::size_t f = 0; f < all.size(); ++f) all[f] = static_cast<std::int32_t>(f);
        const BackgroundPatch target(to, std::move(all), false);
        // Samples: vertices, then per face the centroid and the three edge midpoints.
        const std::size_t nv = from.vertex_count(), nf = from.face_count();
        std::vector<double> dist(nv + 4 * nf, 0.0);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv + nf, 512), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                if (i < nv) {
                    dist[i] = target.project(from.point(static_cast<std::int32_t>(i))).distance;
                    continue;
                }
                const auto& t = from.faces[i - nv];
                const Eigen::Vector3d p0 = from.point(t[0]), p1 = from.point(t[1]),
                                      p2 = from.point(t[2]);
                const Eigen::Vector3d samples[4] = {(p0 + p1 + p2) / 3.0, 0.5 * (p0 + p1),
                                                    0.5 * (p1 + p2), 0.5 * (p2 + p0)};
                for (int k = 0; k < 4; ++k)
                    dist[nv + 4 * (i - nv) + std::size_t(k)] = target.project(samples[k]).distance;
            }
        });
        max_out = 0.0;
        double sum = 0.0;
        for (const double d : dist) {
            max_out = std::max(max_out, d);
            sum += d;
        }
        mean_out = dist.empty() ? 0.0 : sum / double(dist.size());
    };
    HausdorffDistance h;
    if (a.face_count() == 0 || b.face_count() == 0)
        FM_THROW(InputError, "hausdorff_distance: empty surface");
    one_way(a, b, h.a_to_b, h.mean_a_to_b);
    one_way(b, a, h.b_to_a, h.mean_b_to_a);
    return h;
}

SurfaceQuality surface_quality(const core::SurfaceNetwork& s) {
    SurfaceQuality q;
    q.faces = s.face_count();
    if (q.faces == 0) return q;
    std::size_t below_20 = 0, at_least_30 = 0;
    double eta_sum = 0.0;
    for (const auto& t : s.faces) {
        const Eigen::Vector3d a = s.point(t[0]), b = s.point(t[1]), c = s.point(t[2]);
        const double angle = core::triangle_min_angle_deg(a, b, c);
        const double eta = core::triangle_skewness(a, b, c);  // Eq. 2
        q.min_angle_deg = std::min(q.min_angle_deg, angle);
        q.max_eta = std::max(q.max_eta, eta);
        eta_sum += eta;
        if (angle < 20.0) ++below_20;
        if (angle >= 30.0) ++at_least_30;
        const auto bin = std::min<std::size_t>(9, std::size_t(std::max(0.0, eta) * 10.0));
        ++q.eta_histogram[bin];
    }
    q.mean_eta = eta_sum / double(q.faces);
    q.fraction_below_20_deg = double(below_20) / double(q.faces);
    q.fraction_at_least_30_deg = double(at_least_30) / double(q.faces);
    return q;
}

double edge_length_fraction(const core::SurfaceNetwork& s, double lo, double hi) {
    const EdgeTable et = edge_table(s);
    if (et.edge_count() == 0) return 0.0;
    std::size_t inside = 0;
    for (const auto& e : et.vertices) {
        const double len = (s.point(e[0]) - s.point(e[1])).norm();
        if (len >= lo && len <= hi) ++inside;
    }
    return double(inside) / double(et.edge_count());
}

}  // namespace frontmesh::surface
