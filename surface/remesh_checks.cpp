// Checks of one remesh round's result (paper §2: the surface must stay water-tight, and "the
// surface of interest is re-triangulated ... to the desired degree"): every region a closed,
// oriented 2-manifold, its enclosed volume kept, no faces crossing; and the figures of the
// final result.

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "pipeline/core/self_intersection.h"
#include "surface/remesh_internal.h"

namespace frontmesh::surface::remesh_detail {

namespace {

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

// The place of the first edge of `bad` for a message: its midpoint and the patches of its
// faces that bound `region`.
std::string bad_edge_place(const core::SurfaceNetwork& out, const EdgeTable& et,
                           const std::vector<std::int32_t>& face_patch, core::Label region,
                           const std::vector<std::int32_t>& bad) {
    if (bad.empty()) return {};
    const auto e = std::size_t(bad.front());
    std::string patches;
    for (auto k = et.face_offsets[e]; k < et.face_offsets[e + 1]; ++k) {
        const auto f = std::size_t(et.edge_faces[std::size_t(k)]);
        if (out.region_in[f] == region || out.region_out[f] == region)
            patches += " " + std::to_string(face_patch[f]);
    }
    return " (e.g. the edge at " + point_text(edge_midpoint(out, et, bad.front())) +
           ", faces of patches" + patches + ")";
}

// Parts of a region's boundary turned inside out (core::inverted_parts): the two sides of a
// region thinner than h, each met by its own front on the same few curve points, crossed
// through each other; every edge is in order, so only the winding shows it (torture seed
// 12). Meshed again finer there, or with the background's triangles (on_bad_faces).
void check_inverted_parts(const core::SurfaceNetwork& out,
                          const std::vector<std::int32_t>& face_patch, bool last_round, int round,
                          RetryPolicy& retry, core::StageContext& ctx, RegionChecks& result) {
    const std::vector<core::InvertedPart> inverted = core::inverted_parts(out);
    ctx.count("remesh.inverted_parts", double(inverted.size()));
    if (inverted.empty()) return;
    const core::InvertedPart& first = inverted.front();
    if (last_round)
        FM_THROW(GeometryError, "remesh: region " + std::to_string(first.region) +
                                    ": a part of its boundary is turned inside out near " +
                                    point_text(first.place) + " (patch " +
                                    std::to_string(face_patch[std::size_t(first.faces.front())]) +
                                    "); try a smaller remesh.edge_length there");
    std::vector<std::int32_t> faces;
    for (const core::InvertedPart& part : inverted)
        faces.insert(faces.end(), part.faces.begin(), part.faces.end());
    retry.on_bad_faces(faces, out, face_patch, round);
    ctx.warn("remesh: " + std::to_string(inverted.size()) +
             " part(s) of region boundaries turned inside out (e.g. region " +
             std::to_string(first.region) + " near " + point_text(first.place) +
             "); meshing again finer there");
    retry.note(std::to_string(inverted.size()) + " boundary parts were turned inside out");
    result.again = true;
}

}  // namespace

RegionChecks check_regions(const core::SurfaceNetwork& bg, const core::SurfaceNetwork& out,
                           const std::vector<std::int32_t>& face_patch, const Features& features,
                           const RemeshParams& params, int round, RetryPolicy& retry,
                           core::StageContext& ctx) {
    const bool last_round = round + 1 >= RetryPolicy::kRounds;
    RegionChecks result;
    std::optional<EdgeTable> out_edges;  // built only when a region fails its check
    const auto et_of_out = [&]() -> const EdgeTable& {
        if (!out_edges) out_edges = edge_table(out);
        return *out_edges;
    };
    for (const auto& c : core::check_region_boundaries(out)) {
        if (!c.is_closed() || !c.is_oriented() || c.nonmanifold_edges > 0) {
            const std::vector<std::int32_t> bad = edges_not_two_faces(out, et_of_out(), c.region);
            if (!last_round && RetryPolicy::late(round)) {
                // Late: finer sizes would start new stalls; the patches of the faces at the
                // bad edges (or, with every edge in order, all of the region's patches) keep
                // their background triangles, as a late stall does.
                std::vector<std::int32_t> faces;
                for (const std::int32_t e : bad)
                    for (auto k = et_of_out().face_offsets[std::size_t(e)];
                         k < et_of_out().face_offsets[std::size_t(e) + 1]; ++k)
                        faces.push_back(et_of_out().edge_faces[std::size_t(k)]);
                if (bad.empty())
                    for (std::size_t f = 0; f < out.face_count(); ++f)
                        if (out.region_in[f] == c.region || out.region_out[f] == c.region)
                            faces.push_back(static_cast<std::int32_t>(f));
                retry.on_bad_faces(faces, out, face_patch, round);
            } else if (!last_round) {
                // Two patches joined the same two curve points by an inner edge (a short
                // curve between sharp corners): meshed again with finer curves there.
                std::vector<Eigen::Vector3d> midpoints;
                for (const std::int32_t e : bad)
                    midpoints.push_back(edge_midpoint(out, et_of_out(), e));
                retry.on_open_edges(midpoints);
                // Every edge in order but no volume enclosed (the patches of a region thinner
                // than h closed on the same few curve points, or turned inward): no edge to
                // name, so the region's patches are meshed finer as a whole.
                if (bad.empty()) retry.on_collapsed_region(features, c.region);
            }
            if (!last_round) {
                ctx.warn("remesh: region " + std::to_string(c.region) +
                         " is not a closed 2-manifold after the front; " +
                         (RetryPolicy::late(round)
                              ? "its patches there keep their background triangles"
                              : "meshing again with half the size there"));
                retry.note("region " + std::to_string(c.region) + " was not a closed 2-manifold");
                result.again = true;
                break;
            }
            // Name the defect: with every edge in order, the region encloses no volume
            // (its faces collapsed or turned inward), which the edge counts do not show.
            std::ostringstream volumes;
            volumes << "; it encloses " << c.volume << " mm^3 (the background "
                    << core::enclosed_volume(bg, c.region) << " mm^3)";
            FM_THROW(GeometryError,
                     "remesh: region " + std::to_string(c.region) + " has " +
                         std::to_string(c.open_edges) + " open, " +
                         std::to_string(c.misoriented_edges) + " misoriented, " +
                         std::to_string(c.nonmanifold_edges) +
                         " non-manifold edges after remeshing" +
                         (bad.empty() && c.volume <= 0.0 ? volumes.str() : std::string()) +
                         bad_edge_place(out, et_of_out(), face_patch, c.region, bad));
        }
        const double before = core::enclosed_volume(bg, c.region);
        const double change = before != 0.0 ? 100.0 * (c.volume - before) / before : 0.0;
        ctx.count("remesh.volume_change_percent.region_" + std::to_string(c.region), change);
        const double limit = params.max_volume_change_percent;
        if (limit > 0.0 && std::abs(change) > limit) {
            // Late rounds do not rescale: new sizes there would start new stalls in the
            // rounds meant to settle them (inia19, jhu189: a late rescale of many patches
            // stalled 24 of them again); preserve_volumes corrects what is left.
            if (!RetryPolicy::late(round) && !retry.frugal()) {
                retry.on_volume_change(features, c.region, change, limit);
                result.rescaled.append(" ").append(std::to_string(c.region)).append(" (");
                result.rescaled.append(std::to_string(change)).append(" %)");
            } else {
                result.volume_warnings.push_back(
                    "remesh: region " + std::to_string(c.region) + " changed its volume by " +
                    std::to_string(change) + " %, more than remesh.max_volume_change_percent");
            }
        }
    }
    if (!result.again) check_inverted_parts(out, face_patch, last_round, round, retry, ctx, result);
    if (!result.rescaled.empty()) {
        retry.update_vertex_scales();
        retry.note("regions" + result.rescaled + " changed their volume");
    }
    return result;
}

bool check_inverted_after_mend(const core::SurfaceNetwork& out,
                               const std::vector<std::int32_t>& face_patch, int round,
                               RetryPolicy& retry, core::StageContext& ctx) {
    RegionChecks result;
    check_inverted_parts(out, face_patch, round + 1 >= RetryPolicy::kRounds, round, retry, ctx,
                         result);
    return result.again;
}

// Region wedges the mend closed: under kMendWedgeDeg after it and not before (the smoothing's
// wedge pass had opened them; the mend put their vertices back where the front made them).
// HarvardOxford-cort: region 17 kept two wedges of 1.55 and 1.88 degrees that way, and its
// tets there had the same angles. Not the last round: meshed again finer there, true.
constexpr double kMendWedgeDeg = 12.0;

bool mend_closed_wedges(const std::vector<double>& smoothed_xyz, const core::SurfaceNetwork& out,
                        const std::vector<std::int32_t>& face_patch, int round, RetryPolicy& retry,
                        core::StageContext& ctx) {
    if (round + 1 >= RetryPolicy::kRounds) return false;
    core::SurfaceNetwork smoothed = out;  // a mend happened: rare, and O(faces) as the rest
    smoothed.xyz = smoothed_xyz;
    std::vector<std::vector<std::int32_t>> before;
    for (const ThinWedge& w : thin_region_wedges(smoothed, kMendWedgeDeg))
        before.push_back(w.faces);
    std::sort(before.begin(), before.end());
    std::vector<std::int32_t> faces;
    std::size_t closed = 0;
    Eigen::Vector3d first = Eigen::Vector3d::Zero();
    for (const ThinWedge& w : thin_region_wedges(out, kMendWedgeDeg)) {
        if (std::binary_search(before.begin(), before.end(), w.faces)) continue;
        if (closed++ == 0) first = w.midpoint;
        faces.insert(faces.end(), w.faces.begin(), w.faces.end());
    }
    ctx.add("remesh.wedges_closed_by_mend", double(closed));  // over the rounds
    if (closed == 0) return false;
    retry.on_bad_faces(faces, out, face_patch, round);
    ctx.warn("remesh: " + std::to_string(closed) + " region wedge(s) closed under " +
             std::to_string(std::lround(kMendWedgeDeg)) +
             " degrees where crossing faces were put back (e.g. near " + point_text(first) +
             "); meshing again finer there");
    retry.note(std::to_string(closed) + " region wedges closed by the mend");
    return true;
}

bool mend_self_intersections(core::SurfaceNetwork& out, const std::vector<double>& front_xyz,
                             const std::vector<std::int32_t>& face_patch, int round,
                             RetryPolicy& retry, core::StageContext& ctx) {
    // A local fix: vertices of intersecting faces go back to where the front put them
    // (smoothing moved them); a few passes, then the first remaining pair is an error.
    auto pairs = core::self_intersections(out, 1000);
    ctx.count("remesh.self_intersections_after_smoothing", double(pairs.size()));
    for (int pass = 0; pass < 3 && !pairs.empty(); ++pass) {
        for (const auto& [f, g] : pairs)
            for (const std::int32_t face : {f, g})
                for (const auto v : out.faces[std::size_t(face)])
                    for (int k = 0; k < 3; ++k)
                        out.xyz[3 * std::size_t(v) + std::size_t(k)] =
                            front_xyz[3 * std::size_t(v) + std::size_t(k)];
        pairs = core::self_intersections(out, 1000);
    }
    ctx.count("remesh.self_intersections", double(pairs.size()));
    if (pairs.empty()) return false;
    if (round + 1 < RetryPolicy::kRounds) {
        // Meshed again with half the size around each crossing (two patches meeting at a
        // sharp angle, or a gap narrower than the smallest size): the finer the triangles,
        // the closer they follow the background, which does not intersect. A patch whose
        // faces still cross after two rounds of finer sizes (two sheets meeting in a cusp
        // along a curve) keeps its background triangles instead.
        std::vector<std::int32_t> faces;
        for (const auto& [f, g] : pairs) faces.insert(faces.end(), {f, g});
        retry.on_bad_faces(faces, out, face_patch, round);
        ctx.warn(
            "remesh: " + std::to_string(pairs.size()) +
            " pairs of faces intersect after smoothing; meshing again with half the size there");
        retry.note(std::to_string(pairs.size()) + " pairs of faces intersected");
        return true;
    }
    const auto& t = out.faces[std::size_t(pairs[0].first)];
    const Eigen::Vector3d c = (out.point(t[0]) + out.point(t[1]) + out.point(t[2])) / 3.0;
    FM_THROW(GeometryError,
             "remesh: faces " + std::to_string(pairs[0].first) + " and " +
                 std::to_string(pairs[0].second) + " intersect near " + point_text(c) +
                 " (region " + std::to_string(out.region_in[std::size_t(pairs[0].first)]) +
                 ", patches " + std::to_string(face_patch[std::size_t(pairs[0].first)]) + " and " +
                 std::to_string(face_patch[std::size_t(pairs[0].second)]) +
                 "); try a smaller remesh.edge_length there");
}

// Region wedges under kUnmeshableWedgeDeg at junction edges (thin_region_wedges): every
// tet of the region on such an edge is as flat, and one of zero angle (the smoothing closed a
// region on itself where labels meet at a point, torture seed 67: 0.0 and 8.5e-7 degrees)
// has none that is not degenerate. Meshed again finer there, or with the background's
// triangles (on_bad_faces).
bool check_unmeshable_wedges(const core::SurfaceNetwork& out,
                             const std::vector<std::int32_t>& face_patch, int round,
                             RetryPolicy& retry, core::StageContext& ctx) {
    const std::vector<ThinWedge> wedges = thin_region_wedges(out, kUnmeshableWedgeDeg);
    if (wedges.empty()) return false;
    const ThinWedge& first = wedges.front();
    if (round + 1 >= RetryPolicy::kRounds)
        FM_THROW(GeometryError, "remesh: a region closes on itself at the edge near " +
                                    point_text(first.midpoint) + " (its wedge there is " +
                                    std::to_string(first.wedge_deg) +
                                    " degrees); try a smaller remesh.edge_length there");
    std::vector<std::int32_t> faces;
    for (const ThinWedge& w : wedges) faces.insert(faces.end(), w.faces.begin(), w.faces.end());
    retry.on_bad_faces(faces, out, face_patch, round);
    ctx.warn("remesh: " + std::to_string(wedges.size()) + " region wedge(s) under " +
             std::to_string(kUnmeshableWedgeDeg) + " degrees (e.g. near " +
             point_text(first.midpoint) + "); meshing again finer there");
    retry.note(std::to_string(wedges.size()) + " region wedges were flat");
    return true;
}

RemeshResult finished_result(const SizeField& size, core::SurfaceNetwork out,
                             const std::vector<std::int32_t>& vertex_face, std::size_t curve_points,
                             core::StageContext& ctx) {
    RemeshResult result;
    result.target_size.resize(out.vertex_count());
    for (std::size_t v = 0; v < out.vertex_count(); ++v) {
        // Curve points may have slid off their face hint: use the nearest background vertex.
        const std::int32_t face = v < curve_points ? -1 : vertex_face[v];
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

}  // namespace frontmesh::surface::remesh_detail
