// The remesh stage (paper §2): the background surface re-triangulated by the direct
// advancing front. remesh() is a short driver over the paper's steps; the file map of the
// stage is in surface/remesh_internal.h.
//
//   features -> size field -> rounds of { curves -> front per patch -> one network ->
//   smoothing -> checks }, each round meshed again finer where the last one failed
//   (RetryPolicy) -> the result and its figures.

#include "surface/remesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "pipeline/core/self_intersection.h"
#include "surface/remesh_internal.h"
#include "surface/volume_correction.h"

namespace frontmesh::surface {

namespace remesh_detail {

std::string point_text(const Eigen::Vector3d& p) {
    std::ostringstream out;
    out << "(" << p.x() << ", " << p.y() << ", " << p.z() << ") mm";
    return out.str();
}

}  // namespace remesh_detail

using namespace remesh_detail;

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

// --- the size field from the recipe -------------------------------------------------------

// The size field's parameters are the recipe's remesh.* keys with h resolved (§2: "by
// specifying node distribution on the features, the local mesh density can be easily
// controlled"). build_size_field turns them into the per-vertex field; RetryPolicy scales it.
SizeFieldParams size_field_params(const RemeshParams& params, const core::SurfaceNetwork& bg) {
    SizeFieldParams sp;
    sp.edge_length = resolved_edge_length(params, bg);
    sp.gradation = params.gradation;
    sp.min_edge_length = params.min_edge_length;
    sp.max_edge_length = params.max_edge_length;
    sp.curvature_angle_deg = params.curvature_angle_deg;
    sp.thickness_layers = params.thickness_layers;
    sp.label_edge_length = params.label_edge_length;
    return sp;
}

void check_background(const core::SurfaceNetwork& bg) {
    if (bg.face_count() == 0) FM_THROW(InputError, "remesh: the background surface is empty");
    for (const auto& c : core::check_region_boundaries(bg))
        if (!c.is_closed())
            FM_THROW(InputError, "remesh: region " + std::to_string(c.region) +
                                     " of the background is not closed (run repair first)");
}

// --- the front per patch ------------------------------------------------------------------

// What stays from one round to the next per patch: a patch whose loops, copy state and sizes
// are those of a round it was meshed in keeps that mesh (the front is deterministic, so the
// result is the same, and a round costs only the patches it changes).
struct PatchCache {
    std::vector<BackgroundPatch> patches;  // the background of each patch
    std::vector<core::AdtBox> box;         // bounding box of each patch's background
    std::vector<PatchMesh> meshes;
    std::vector<core::StageContext> contexts;  // of the last meshing: counters and warnings
    std::vector<std::vector<PatchLoop>> meshed_loops;
    std::vector<std::uint8_t> meshed, meshed_copy;
    // The recipe's size for each patch (remesh.edge_length resolved, or the smaller size of
    // its two regions' labels): what tells a shell smaller than h (is_small_closed_patch).
    std::vector<double> nominal_h;

    PatchCache(const core::SurfaceNetwork& bg, const Features& features,
               const SizeFieldParams& sp) {
        for (std::size_t p = 0; p < features.patches.size(); ++p)
            add_new(bg, features.patches[p], sp);
    }

    // After cuts (cut_patches): a patch with the same faces as old patch old_of_new[q] keeps
    // what the cache holds for it, the others start empty.
    PatchCache(PatchCache&& old, const std::vector<std::int32_t>& old_of_new,
               const core::SurfaceNetwork& bg, const Features& features,
               const SizeFieldParams& sp) {
        for (std::size_t q = 0; q < old_of_new.size(); ++q) {
            const std::int32_t p = old_of_new[q];
            if (p < 0) {
                add_new(bg, features.patches[q], sp);
                continue;
            }
            const auto i = std::size_t(p);
            patches.push_back(std::move(old.patches[i]));
            box.push_back(old.box[i]);
            meshes.push_back(std::move(old.meshes[i]));
            contexts.push_back(std::move(old.contexts[i]));
            meshed_loops.push_back(std::move(old.meshed_loops[i]));
            meshed.push_back(old.meshed[i]);
            meshed_copy.push_back(old.meshed_copy[i]);
            nominal_h.push_back(old.nominal_h[i]);
        }
    }

private:
    void add_new(const core::SurfaceNetwork& bg, const Patch& patch, const SizeFieldParams& sp) {
        patches.emplace_back(bg, patch.faces, false);
        const auto& fv = bg.faces[std::size_t(patch.faces.front())];
        core::AdtBox b = core::AdtBox::of_point(bg.point(fv[0]));
        for (const std::int32_t f : patch.faces)
            for (const std::int32_t v : bg.faces[std::size_t(f)]) b.extend(bg.point(v));
        box.push_back(b);
        meshes.emplace_back();
        contexts.emplace_back();
        meshed_loops.emplace_back();
        meshed.push_back(0);
        meshed_copy.push_back(0);
        double h = sp.edge_length;
        for (const core::Label label : {patch.region_in, patch.region_out}) {
            const auto it = sp.label_edge_length.find(label);
            if (it != sp.label_edge_length.end()) h = std::min(h, it->second);
        }
        nominal_h.push_back(h);
    }
};

// Patches to mesh this round: those not meshed yet with the same loops, copy state and sizes.
std::vector<std::uint8_t> patches_to_mesh(const PatchLoops& loops, const PatchCache& cache,
                                          const RetryPolicy& retry) {
    const std::size_t np = cache.meshes.size();
    std::vector<std::uint8_t> dirty(np, 0);
    for (std::size_t p = 0; p < np; ++p) {
        bool same = cache.meshed[p] && cache.meshed_copy[p] == retry.copy(p) &&
                    cache.meshed_loops[p].size() == loops.loops[p].size();
        for (std::size_t l = 0; same && l < loops.loops[p].size(); ++l)
            same = cache.meshed_loops[p][l].points == loops.loops[p][l].points;
        dirty[p] = !same || retry.has_new_sizes(p, cache.box[p]);
    }
    return dirty;
}

// The triangles the front is expected to make on the `dirty` patches it meshes (not those
// copied): area / (sqrt(3)/4 h^2) per background face, h at its centroid (RetryPolicy::spend).
double expected_front_triangles(const core::SurfaceNetwork& bg, const Features& features,
                                const std::vector<std::uint8_t>& dirty, const RetryPolicy& retry) {
    double n = 0.0;
    for (std::size_t p = 0; p < features.patches.size(); ++p) {
        if (!dirty[p] || retry.copy(p)) continue;
        for (const std::int32_t f : features.patches[p].faces) {
            const auto& t = bg.faces[std::size_t(f)];
            const Eigen::Vector3d a = bg.point(t[0]), b = bg.point(t[1]), c = bg.point(t[2]);
            const double h = retry.size((a + b + c) / 3.0, f);
            if (h > 0.0) n += 0.5 * (b - a).cross(c - a).norm() / (0.4330127 * h * h);
        }
    }
    return n;
}

std::string format_ratio(double r) {
    std::ostringstream s;
    s << std::setprecision(3) << r;
    return s.str();
}

// A copied patch with loops: its edges shorter than this times the longest edge at their
// ends collapse (coarsen_patch, light).
constexpr double kCopyCollapseBelow = 0.3;

// §2: the advancing front applied directly in 3-D on each patch (TBB-parallel over patches,
// each with a child context). A patch whose front stalls is recorded (patch order decides
// which error is reported, so the result does not depend on the threads).

std::vector<std::optional<FrontStall>> mesh_patches(const core::SurfaceNetwork& bg,
                                                    const Features& features,
                                                    const PatchLoops& loops,
                                                    const std::vector<std::uint8_t>& dirty,
                                                    const RetryPolicy& retry, PatchCache& cache,
                                                    core::StageContext& ctx) {
    const std::size_t np = cache.meshes.size();
    const SizeFunction size_function = retry.size_function();
    const FrontParams fp;
    std::vector<std::optional<FrontStall>> stalls(np);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, np, 1), [&](const auto& range) {
        for (std::size_t p = range.begin(); p != range.end(); ++p) {
            if (!dirty[p]) continue;
            ctx.check_cancelled();
            cache.meshed[p] = 0;
            cache.contexts[p] = ctx.child();
            try {
                const Patch& patch = features.patches[p];
                if (retry.copy(p) && !patch.loops.empty()) {
                    // Bounded by curves, it lies beside other patches, often across a thin
                    // layer: its background triangles stay (a coarsened or split copy crossed
                    // its neighbours after smoothing, torture seed 24) but for the needles of
                    // a marching-cubes background, whose short edges collapse.
                    cache.meshes[p] = coarsen_patch(
                        cache.patches[p],
                        copy_background_patch(bg, patch, loops.bg[p], loops.merged[p]),
                        loops.bg[p].size(), size_function, kCopyCollapseBelow);
                } else if (retry.copy(p)) {
                    cache.meshes[p] = coarsen_patch(
                        cache.patches[p], copy_background_patch(bg, patch, {}), 0, size_function);
                } else if (patch.loops.empty() &&
                           is_small_closed_patch(cache.patches[p], size_function,
                                                 cache.nominal_h[p])) {
                    cache.meshes[p] = coarsen_patch(
                        cache.patches[p], copy_background_patch(bg, patch, {}), 0, size_function);
                    cache.contexts[p].add("remesh.patches_coarse", 1.0);
                } else {
                    cache.meshes[p] = triangulate_patch(cache.patches[p], loops.loops[p],
                                                        size_function, fp, cache.contexts[p]);
                }
                cache.meshed[p] = 1;
                cache.meshed_copy[p] = retry.copy(p);
                cache.meshed_loops[p] = loops.loops[p];
            } catch (const FrontStall& e) {
                stalls[p] = e;
            }
        }
    });
    return stalls;
}

// Stalled patches get finer sizes there or keep their background triangles (RetryPolicy);
// in the last round the first stall in patch order is the error. Returns whether any stalled.
bool handle_stalls(const std::vector<std::optional<FrontStall>>& stalls, const Features& features,
                   int round, RetryPolicy& retry, core::StageContext& ctx) {
    std::size_t stalled = 0;
    std::string places;
    for (std::size_t p = 0; p < stalls.size(); ++p) {
        if (!stalls[p]) continue;
        if (++stalled <= 4) places.append(" ").append(point_text(stalls[p]->place()));
        if (round + 1 >= RetryPolicy::kRounds) throw *stalls[p];
        retry.on_stall(p, features.patches[p].faces.size(), stalls[p]->places(), round);
    }
    if (stalled == 0) return false;
    ctx.warn("remesh: the front stalled in " + std::to_string(stalled) + " patch(es) (near" +
             places +
             "); meshing again with half the size there (a patch stalling twice keeps its "
             "background triangles around the places where it stalled)");
    retry.note("the front stalled in " + std::to_string(stalled) + " patch(es)");
    return true;
}

// Warnings a child context has logged already, recorded in ctx without logging them again
// (merge_from would add the counters too, which the rounds sum on their own).
void record_logged_warnings(core::StageContext& ctx, const core::StageContext& child) {
    core::StageContext warnings_only;  // no sinks: warn() only records
    for (const auto& w : child.warnings()) warnings_only.warn(w);
    ctx.merge_from(warnings_only);
}

// Counters and warnings of the patches, in patch order; the copied patches reported.
// Each copied patch is named by its regions and the centre of its bounding box (the first
// four in patch order), so that a user can find the place.
void report_patches(const Features& features, const PatchCache& cache, const RetryPolicy& retry,
                    std::map<std::string, double>& round_sums, core::StageContext& ctx) {
    const std::size_t np = cache.meshes.size();
    std::size_t copied = 0, copied_faces = 0;
    std::string places;
    for (std::size_t p = 0; p < np; ++p) {
        if (!retry.copy(p)) continue;
        if (++copied <= 4) {
            const Patch& patch = features.patches[p];
            places += (copied > 1 ? "; " : " (") + std::string("regions ") +
                      std::to_string(patch.region_in) + "/" + std::to_string(patch.region_out) +
                      " near " + point_text(0.5 * (cache.box[p].lo + cache.box[p].hi));
        }
        copied_faces += cache.meshes[p].faces.size();
    }
    ctx.count("remesh.patches_copied_from_background", double(copied));
    ctx.count("remesh.faces_copied_from_background", double(copied_faces));
    if (copied > 0)
        ctx.warn("remesh: " + std::to_string(copied) + " patch(es)" + places +
                 (copied > 4 ? "; ...)" : ")") + ", " + std::to_string(copied_faces) +
                 " faces, keep their background triangles (smoothed only; closed ones split and "
                 "coarsened): the front stalled there twice or late, or faces crossed three "
                 "times");
    for (std::size_t p = 0; p < np; ++p) {
        for (const auto& [name, value] : cache.contexts[p].counters()) round_sums[name] += value;
        record_logged_warnings(ctx, cache.contexts[p]);
    }
}

// --- one network --------------------------------------------------------------------------

// The patch meshes joined into `out` after the curve points: loop points are the shared
// curve points, exactly. Returns the patch of each output face.
std::vector<std::int32_t> assemble_patches(const Features& features, const PatchLoops& loops,
                                           const PatchCache& cache, core::SurfaceNetwork& out,
                                           std::vector<std::int32_t>& vertex_face) {
    std::vector<std::int32_t> face_patch;
    for (std::size_t p = 0; p < cache.meshes.size(); ++p) {
        const PatchMesh& mesh = cache.meshes[p];
        const std::size_t nloop = loops.ids[p].size();
        FM_CHECK(mesh.points.size() >= nloop && mesh.point_face.size() == mesh.points.size());
        std::vector<std::int32_t> map(mesh.points.size());
        for (std::size_t k = 0; k < nloop; ++k) {
            map[k] = loops.ids[p][k];
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
    return face_patch;
}

// Two patches that both joined the same two curve points by an inner edge (a thin lens
// between two curves) would make that edge non-manifold: the edge is flipped inside the
// later patch (the other diagonal of its two faces there) when both new faces keep the
// orientation of the old ones and the diagonal is not an edge yet. Returns the flips made.
std::size_t flip_shared_inner_edges(core::SurfaceNetwork& out,
                                    const std::vector<std::int32_t>& face_patch,
                                    std::size_t curve_points) {
    std::size_t flips = 0;
    for (int sweep = 0; sweep < 3; ++sweep) {
        const EdgeTable et = edge_table(out);
        std::set<std::pair<std::int32_t, std::int32_t>> edges;
        for (const auto& e : et.vertices) edges.insert({e[0], e[1]});
        std::vector<std::uint8_t> touched(out.face_count(), 0);
        std::size_t made = 0;
        for (std::size_t e = 0; e < et.edge_count(); ++e) {
            // Not a structured binding: clang 14 (the sanitizer build) cannot capture one.
            const auto x = et.vertices[e][0], y = et.vertices[e][1];
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
                    if (tg[std::size_t(j)] == y && tg[std::size_t((j + 1) % 3)] == x)
                        d = tg[std::size_t((j + 2) % 3)];
                if (d < 0 || c == d || edges.count({std::min(c, d), std::max(c, d)})) continue;
                const std::array<std::int32_t, 3> nf{c, x, d}, ng{d, y, c};
                auto normal = [&](const std::array<std::int32_t, 3>& t) {
                    return Eigen::Vector3d((out.point(t[1]) - out.point(t[0]))
                                               .cross(out.point(t[2]) - out.point(t[0])));
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

// --- smoothing ----------------------------------------------------------------------------

// What the smoothing may do with each output vertex: stay on its patch, slide along its
// curve, or (a corner) stay.
SurfaceConstraints surface_constraints(const core::SurfaceNetwork& bg, const Features& features,
                                       const std::vector<DiscreteCurve>& curves,
                                       std::vector<std::int32_t> face_patch,
                                       const std::vector<std::int32_t>& vertex_face) {
    SurfaceConstraints constraints;
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
    return constraints;
}

// §2: "an angle-based smoothing method is applied to the resulting mesh to ensure quality",
// with projection onto the background, curve vertices on their curves, and edge flips.
void smooth(core::SurfaceNetwork& out, const std::vector<const BackgroundPatch*>& pointers,
            SurfaceConstraints& constraints, const RemeshParams& params,
            std::map<std::string, double>& round_sums) {
    if (params.smoothing_iterations <= 0) return;
    SmoothingParams smp;
    smp.iterations = params.smoothing_iterations;
    smp.flip_max_dihedral_deg = params.flip_max_dihedral_deg;
    core::StageContext sub;
    smooth_surface(out, pointers, constraints, smp, sub);
    for (const auto& [name, value] : sub.counters()) round_sums[name] += value;
}

// --- one round ----------------------------------------------------------------------------

// Faces with an angle over this have their longest edge split before the smoothing (a
// surface triangle over about 130 degrees forces a tet skewness over 0.8), unless a new face
// would get an angle under min(its old smallest, kSplitGuardDeg).
constexpr double kSplitAboveDeg = 120.0;
constexpr double kSplitGuardDeg = 20.0;

// What a round makes; the last round's is the result.
struct RoundResult {
    core::SurfaceNetwork out;
    SurfaceConstraints constraints;
    std::size_t curve_points = 0;
    // Counters summed over patches and passes: those of the last round only are reported.
    std::map<std::string, double> sums;
};

// Everything a round reads and what it keeps for the next.
struct Rounds {
    const core::SurfaceNetwork& bg;
    const RemeshParams& params;
    const Features& features;
    RetryPolicy& retry;
    PatchCache& cache;
    StepClock& clock;
    core::StageContext& ctx;
};

// Curves, front per patch, one network, smoothing and checks (§2 in order). Returns true when
// the round's result stands, false when RetryPolicy asks for another round.
bool mesh_round(int round, Rounds& r, RoundResult& result) {
    core::StageContext& ctx = r.ctx;
    ctx.count("remesh.rounds", double(round + 1));
    ctx.info(r.retry.round_summary(round));
    result.sums.clear();

    ctx.progress(0.15, "curves");
    core::SurfaceNetwork& out = result.out;
    out = core::SurfaceNetwork();
    std::vector<std::int32_t> vertex_face;
    const std::vector<DiscreteCurve> curves =
        place_curve_points(r.bg, r.features, r.retry, out, vertex_face);
    result.curve_points = out.vertex_count();
    ctx.count("remesh.curve_points", double(result.curve_points));

    ctx.progress(0.2, "advancing front");
    const PatchLoops loops = patch_loops(r.features, curves, out);
    ctx.count("remesh.patches_with_repeated_loop_points",
              double(patches_with_repeated_loop_points(loops)));
    const std::vector<std::uint8_t> dirty = patches_to_mesh(loops, r.cache, r.retry);
    if (r.retry.spend(expected_front_triangles(r.bg, r.features, dirty, r.retry)))
        ctx.warn("remesh: round " + std::to_string(round + 1) + " brings the rounds' work to " +
                 format_ratio(r.retry.work_ratio()) +
                 " times the first round's; from now on a patch whose front stalls or whose faces "
                 "cross keeps its background triangles");
    ctx.count("remesh.work_ratio", r.retry.work_ratio());
    r.retry.mark_sizes_used();
    ctx.count("remesh.patches_meshed_in_last_round",
              double(std::count(dirty.begin(), dirty.end(), 1)));
    const auto stalls = mesh_patches(r.bg, r.features, loops, dirty, r.retry, r.cache, ctx);
    if (handle_stalls(stalls, r.features, round, r.retry, ctx)) return false;
    report_patches(r.features, r.cache, r.retry, result.sums, ctx);

    ctx.progress(0.6, "assembly");
    std::vector<std::int32_t> face_patch =
        assemble_patches(r.features, loops, r.cache, out, vertex_face);
    ctx.count("remesh.front_faces", double(out.face_count()));
    result.sums["remesh.shared_inner_edges_flipped"] +=
        double(flip_shared_inner_edges(out, face_patch, result.curve_points));
    r.clock.lap("front");

    ctx.progress(0.7, "smoothing");
    result.constraints =
        surface_constraints(r.bg, r.features, curves, std::move(face_patch), vertex_face);
    std::vector<const BackgroundPatch*> pointers;
    for (const auto& p : r.cache.patches) pointers.push_back(&p);
    result.sums["remesh.obtuse_splits"] += double(
        split_obtuse_faces(out, pointers, result.constraints, kSplitAboveDeg, kSplitGuardDeg));
    const std::vector<double> front_xyz = out.xyz;  // positions before smoothing
    smooth(out, pointers, result.constraints, r.params, result.sums);
    r.clock.lap("smoothing");

    ctx.progress(0.9, "checks");
    const std::vector<std::int32_t>& patch_of = result.constraints.face_patch;
    const RegionChecks regions =
        check_regions(r.bg, out, patch_of, r.features, r.params, round, r.retry, ctx);
    const std::vector<double> smoothed_xyz = out.xyz;  // as check_regions saw it
    if (regions.again) return false;
    if (r.params.check_self_intersections &&
        mend_self_intersections(out, front_xyz, patch_of, round, r.retry, ctx))
        return false;
    // The mend moved vertices back after check_regions: a part can be inside out only now
    // (torture seed 176 with a balanced manifold clean-up: 92 faces of region 2, and tetra
    // then ran for over 28 minutes on that surface).
    // The mend may also close a wedge the smoothing had opened (HarvardOxford-cort).
    if (out.xyz != smoothed_xyz &&
        (mend_closed_wedges(smoothed_xyz, out, patch_of, round, r.retry, ctx) ||
         check_inverted_after_mend(out, patch_of, round, r.retry, ctx)))
        return false;
    if (check_unmeshable_wedges(out, patch_of, round, r.retry, ctx)) return false;
    if (!regions.rescaled.empty()) {
        ctx.warn("remesh: regions" + regions.rescaled +
                 " changed their volume more than remesh.max_volume_change_percent; meshing them "
                 "again finer");
        return false;
    }
    for (const std::string& w : regions.volume_warnings) ctx.warn(w);
    return true;
}

// The patches of the rounds and what is kept per patch; cut_stalled_patches replaces them.
struct Patches {
    Features features;
    std::vector<std::int32_t> face_part;  // cut_patches' parts per background face
    std::unique_ptr<RetryPolicy> retry;
    std::unique_ptr<PatchCache> cache;
};

// A patch that stalled twice is cut (RetryPolicy::cuts, cut_patches): the features are found
// again with the parts, and the policy and cache carry over to the patches with the same
// faces. Each cut moves faces into a new part, and cuts happen only in rounds (bounded by
// RetryPolicy::kRounds), so the features are found at most kRounds times.
void cut_stalled_patches(const core::SurfaceNetwork& bg, const RemeshParams& params,
                         const SizeField& size, const SizeFieldParams& sp, Patches& patches,
                         core::StageContext& ctx) {
    const auto& cuts = patches.retry->cuts();
    std::string places;
    std::size_t count = 0;
    for (const auto& cut : cuts)
        for (const Eigen::Vector3d& x : cut.places)
            if (++count <= 4) places.append(" ").append(point_text(x));
    const std::int32_t first_new = cut_patches(bg, patches.features, size, cuts, patches.face_part);
    Features cut = find_features(bg, params.feature_angle_deg, ctx, patches.face_part);
    std::vector<std::int32_t> old_of_new(cut.patches.size(), -1);
    std::vector<std::uint8_t> is_cut(cut.patches.size(), 0);
    for (std::size_t q = 0; q < cut.patches.size(); ++q) {
        const std::int32_t f0 = cut.patches[q].faces.front();
        if (patches.face_part[std::size_t(f0)] >= first_new) {
            is_cut[q] = 1;
            continue;
        }
        const std::int32_t p = patches.features.face_patch[std::size_t(f0)];
        if (patches.features.patches[std::size_t(p)].faces == cut.patches[q].faces)
            old_of_new[q] = p;
    }
    ctx.add("remesh.stall_cuts", double(cuts.size()));
    ctx.warn("remesh: the front stalled twice in " + std::to_string(cuts.size()) +
             " patch(es); the background around " + std::to_string(count) + " place(s) (near" +
             places + ") keeps its triangles, cut out of the patch, and the rest is meshed again");
    patches.retry->note("cuts around " + std::to_string(count) + " stall place(s)");
    patches.retry = std::make_unique<RetryPolicy>(std::move(*patches.retry), old_of_new, is_cut);
    patches.cache =
        std::make_unique<PatchCache>(std::move(*patches.cache), old_of_new, bg, cut, sp);
    patches.features = std::move(cut);
}

// The last resort when the last round still fails (`why`): the background itself, which is
// closed and oriented (check_background), when it also has no part turned inside out, no
// crossing faces and no flat wedge; else nullopt (the failure stands). A warning names the failure,
// and `remesh.fallback_to_background` counts it: the result is valid but keeps the background's
// triangles (and their quality) everywhere.
// remesh.preserve_volume: every region back to the background's enclosed volume, offsets of
// at most h / 10 (the sagitta of a chord of length h on a radius of 1.25 h; thinner or more
// curved parts keep part of their loss rather than move further off the background).
void preserve_volumes(const core::SurfaceNetwork& bg, const RemeshParams& params, double h,
                      core::SurfaceNetwork& out, core::StageContext& ctx) {
    if (!params.preserve_volume) return;
    std::map<core::Label, double> target;
    for (const core::Label l : core::region_labels(bg)) target[l] = core::enclosed_volume(bg, l);
    const VolumeCorrection c = correct_region_volumes(out, target, 0.1 * h, 3);
    ctx.count("remesh.volume_error_percent_before", 100.0 * c.worst_before);
    ctx.count("remesh.volume_error_percent", 100.0 * c.worst_after);
    ctx.count("remesh.volume_error_region", static_cast<double>(c.worst_region));
    ctx.count("remesh.vertices_put_back_for_volume", static_cast<double>(c.vertices_put_back));
}

std::optional<RemeshResult> background_result(const core::SurfaceNetwork& bg, const SizeField& size,
                                              const std::string& why, core::StageContext& ctx) {
    if (!core::inverted_parts(bg).empty() || !core::self_intersections(bg, 1).empty() ||
        !thin_region_wedges(bg, kUnmeshableWedgeDeg).empty())
        return std::nullopt;
    ctx.warn(why +
             "; the repaired surface is used as it is (not remeshed) so that the run "
             "goes on");
    ctx.count("remesh.fallback_to_background", 1.0);
    std::vector<std::int32_t> vertex_face(bg.vertex_count(), -1);
    for (std::size_t f = bg.face_count(); f-- > 0;)
        for (const std::int32_t v : bg.faces[f]) vertex_face[std::size_t(v)] = std::int32_t(f);
    return finished_result(size, bg, vertex_face, 0, ctx);
}

}  // namespace

double default_edge_length(const core::SurfaceNetwork& background) {
    return 2.0 * mean_edge_length(background);
}

double resolved_edge_length(const RemeshParams& params, const core::SurfaceNetwork& background) {
    if (params.edge_length > 0.0) return params.edge_length;
    const double h = default_edge_length(background);
    return params.volume_edge_cap > 0.0 ? std::min(h, params.volume_edge_cap) : h;
}

RemeshResult remesh(const core::SurfaceNetwork& bg, const RemeshParams& params,
                    core::StageContext& ctx) {
    validate(params);
    check_background(bg);

    // §2: "geometrical features are extracted from the background mesh".
    StepClock clock(ctx);
    ctx.progress(0.0, "features");

    // The target size h over the background: remesh.edge_length (resolved), then the field.
    ctx.progress(0.05, "size field");
    const SizeFieldParams sp = size_field_params(params, bg);
    const SizeField size = build_size_field(bg, sp, ctx);
    clock.lap("size_field");
    ctx.count("remesh.edge_length_mm", sp.edge_length);
    // An explicit size is kept even above tetra.max_edge_length (README: "Element size
    // inside the volume"); the tets on triangles wider than the cap are flat there.
    if (params.edge_length > 0.0 && params.volume_edge_cap > 0.0 &&
        params.edge_length > params.volume_edge_cap)
        ctx.warn("remesh: remesh.edge_length " + format_ratio(params.edge_length) +
                 " mm is above tetra.max_edge_length " + format_ratio(params.volume_edge_cap) +
                 " mm: the tets on the surface cannot be smaller than its triangles and are "
                 "flatter there; set remesh.edge_length to at most the cap, or to 0 (the "
                 "automatic size, capped)");

    // Rounds: meshed again finer where a round fails, or with the places where a patch
    // stalled twice cut out of it (bounded by RetryPolicy::kRounds, cuts included; the last
    // round reports what still fails).
    Patches patches{find_features(bg, params.feature_angle_deg, ctx), {}, nullptr, nullptr};
    patches.retry = std::make_unique<RetryPolicy>(bg, size, patches.features.patches.size());
    patches.cache = std::make_unique<PatchCache>(bg, patches.features, sp);
    clock.lap("features");
    ctx.info("remesh: h = " + std::to_string(sp.edge_length) + " mm, " +
             std::to_string(patches.features.patches.size()) + " patches, " +
             std::to_string(patches.features.curves.size()) + " curves");
    RoundResult last;
    for (int round = 0; round + 1 < RetryPolicy::kRounds; ++round) {
        ctx.check_cancelled();
        Rounds rounds{bg, params, patches.features, *patches.retry, *patches.cache, clock, ctx};
        const bool done = mesh_round(round, rounds, last);
        if (!done && !patches.retry->cuts().empty())
            cut_stalled_patches(bg, params, size, sp, patches, ctx);
        if (done) {
            for (const auto& [name, value] : last.sums) ctx.add(name, value);
            preserve_volumes(bg, params, sp.edge_length, last.out, ctx);
            clock.lap("checks");
            return finished_result(size, std::move(last.out), last.constraints.vertex_face,
                                   last.curve_points, ctx);
        }
    }
    ctx.check_cancelled();
    Rounds rounds{bg, params, patches.features, *patches.retry, *patches.cache, clock, ctx};
    try {
        mesh_round(RetryPolicy::kRounds - 1, rounds, last);  // the last: it stands or throws
    } catch (const core::GeometryError& e) {
        if (auto result = background_result(bg, size, e.what(), ctx)) return std::move(*result);
        throw;
    } catch (const core::MeshingError& e) {
        if (auto result = background_result(bg, size, e.what(), ctx)) return std::move(*result);
        throw;
    }
    for (const auto& [name, value] : last.sums) ctx.add(name, value);
    preserve_volumes(bg, params, sp.edge_length, last.out, ctx);
    clock.lap("checks");
    return finished_result(size, std::move(last.out), last.constraints.vertex_face,
                           last.curve_points, ctx);
}

}  // namespace frontmesh::surface
