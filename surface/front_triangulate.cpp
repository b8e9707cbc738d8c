// Direct advancing-front triangulation of one patch over the discrete background surface
// (paper §2; Löhner-style front in 3-D with the 2-D analogue of the §3.1.4 tests).
//
// The front is a set of directed edges with the unmeshed part of the patch on their left
// (seen from the patch normal). Step: take the shortest front edge (a, b); place the ideal
// apex at the target size over it in the tangent plane (Eq. 10 analogue) and project it onto
// the background; rank existing front points near it by Eq. 12 (new point last); accept the
// first candidate passing the validity tests, done in the tangent plane at the edge midpoint
// with exact orient2d on the projected coordinates. An edge failing twice triggers local
// remeshing (§3.2): the triangles around its ends are removed and the front re-opened.
//
// This file: the driver (initial front or seed, the step loop, smoothing inside the patch,
// compaction) and triangulate_patch's attempts; the file map is in surface/front_mesher.h.

#include "surface/front_triangulate.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "surface/front_mesher.h"

namespace frontmesh::surface {

namespace front_detail {

// A closed patch without loops starts from an equilateral triangle of the target size on the
// patch's first face.
void FrontMesher::seed() {
    const core::SurfaceNetwork& bg = patch_.background();
    const auto& faces = patch_.faces();
    const std::int32_t f0 = faces[(static_cast<std::size_t>(attempt_) * 7919u) % faces.size()];
    const auto& fv = bg.faces[static_cast<std::size_t>(f0)];
    const Eigen::Vector3d centre = (bg.point(fv[0]) + bg.point(fv[1]) + bg.point(fv[2])) / 3.0;
    const Eigen::Vector3d n = patch_.smooth_normal(f0);
    Eigen::Vector3d u = n.unitOrthogonal();
    const Eigen::Vector3d v = n.cross(u);
    const double h = size_(centre, f0);
    if (!(h > 0.0)) FM_THROW(MeshingError, "remesh: size field not positive at " + where(centre));
    std::int32_t ids[3];
    for (int k = 0; k < 3; ++k) {
        const double angle = pi / 2.0 + k * two_pi / 3.0;
        const Eigen::Vector3d p =
            centre + h / std::sqrt(3.0) * (std::cos(angle) * u + std::sin(angle) * v);
        const BackgroundPatch::Projection pr = patch_.project(p, f0);
        ids[k] = add_point(pr.point, pr.face, false);
    }
    add_triangle(ids[0], ids[1], ids[2]);
}

PatchMesh FrontMesher::run(const std::vector<PatchLoop>& loops) {
    // Loop points first, in loop order; loop edges are the initial front.
    for (std::size_t l = 0; l < loops.size(); ++l) {
        const auto& pts = loops[l].points;
        if (pts.size() < 3)
            FM_THROW(InputError,
                     "remesh: patch loop " + std::to_string(l) + " has fewer than 3 points");
        const auto first = static_cast<std::int32_t>(xyz_.size());
        for (const Eigen::Vector3d& p : pts) {
            const BackgroundPatch::Projection pr = patch_.project(p);
            add_point(p, pr.face, true);
        }
        const auto n = static_cast<std::int32_t>(pts.size());
        for (std::int32_t i = 0; i < n; ++i) {
            const std::int32_t a = first + i, b = first + (i + 1) % n;
            add_edge(a, b);
            sync_point(a);
        }
    }
    if (loops.empty()) seed();

    // Every step either adds a triangle or counts a failure; both are bounded.
    double h_min = std::numeric_limits<double>::infinity();
    {
        const core::SurfaceNetwork& bg = patch_.background();
        const auto& faces = patch_.faces();
        const std::size_t stride = std::max<std::size_t>(1, faces.size() / 4096);
        for (std::size_t i = 0; i < faces.size(); i += stride) {
            const auto& fv = bg.faces[static_cast<std::size_t>(faces[i])];
            h_min = std::min(
                h_min,
                size_((bg.point(fv[0]) + bg.point(fv[1]) + bg.point(fv[2])) / 3.0, faces[i]));
        }
        for (const Eigen::Vector3d& p : xyz_) h_min = std::min(h_min, size_(p, face_[0]));
    }
    // Work bounds, all proportional to the patch (issue 20: a 10-face patch must not cost
    // seconds). n = the triangles an equilateral mesh at the smallest size would have plus the
    // loop points (a fine loop on a small patch makes triangles of the loop's spacing).
    //  - steps <= 20 n + 400: every step adds a triangle, counts a failure of its edge or
    //    remeshes locally; an edge fails at most twice before remeshing or the last resort
    //    (a front that closes takes about 6 steps per triangle).
    //  - local remeshings <= n / 20 + 20 (and max_local_remesh within one place).
    //  - live triangles <= 4 n + 64: a front that closes makes about n; one that makes far
    //    more winds over its own patch (thin shells, a closed shell smaller than h) and is a
    //    stall, found after O(n) steps instead of after the step limit on a huge front.
    // The loop below ends: each pass pops one queue entry; an entry is pushed when an edge is
    // made (at most 3 per triangle made or removed, triangles removed <= triangles made <= 24
    // per step) or once per counted step (a failure, a put-back, a remeshing), so the pops are
    // O(steps) and steps are bounded above.
    const double expected = patch_.area() / (0.43 * h_min * h_min);
    const double n = std::min(expected + static_cast<double>(xyz_.size()), 1.0e8);
    const std::int64_t max_steps = static_cast<std::int64_t>(20.0 * n) + 400;
    const std::int64_t max_remeshings = static_cast<std::int64_t>(n / 20.0) + 20;
    const std::int64_t max_triangles = static_cast<std::int64_t>(4.0 * n) + 64;
    std::int64_t steps = 0;
    while (!queue_.empty()) {
        const QueueEntry top = queue_.top();
        queue_.pop();
        FrontEdge& fe = edges_[static_cast<std::size_t>(top.edge)];
        if (!fe.alive || fe.fails != top.fails || waits(top.edge)) continue;
        if (++steps > max_steps || live_triangles_ > max_triangles) {
            const Eigen::Vector3d& xa = xyz_[static_cast<std::size_t>(fe.a)];
            const std::string why =
                "remesh: the front does not close (" +
                std::string(live_triangles_ > max_triangles ? "triangle" : "step") +
                " limit) near " + where(xa) + " (" + front_state() + ")";
            hand_over_stall(xa, 8.0, why);
            FrontStall stall(why, xa, __FILE__, __LINE__, __func__);
            stall.add_earlier_places(abandoned_);
            throw stall;
        }
        if ((steps & 0x3fff) == 0) {
            ctx_.check_cancelled();
            ctx_.progress(std::min(1.0, static_cast<double>(live_triangles_) / expected),
                          "front: " + std::to_string(live_triangles_) + " triangles, " +
                              std::to_string(front_size_) + " front edges, " +
                              std::to_string(remeshings_) + " local remeshings");
        }
        if (advance(top.edge, top.fails)) continue;
        FrontEdge& again = edges_[static_cast<std::size_t>(top.edge)];
        ++again.fails;
        if (again.fails < 2)
            queue_.push({again.fails, top.length, top.edge});
        else if (close_small_loop(top.edge))
            continue;
        else if (remeshings_near(top.edge) >= kLastResortAfter && advance(top.edge, 2)) {
            ++last_resort_;
            continue;
        } else if (remeshings_ >= max_remeshings) {
            // By index: advance() may have grown edges_ since `fe` was taken.
            const Eigen::Vector3d& xa =
                xyz_[static_cast<std::size_t>(edges_[static_cast<std::size_t>(top.edge)].a)];
            const std::string why =
                "remesh: the front stalls near " + where(xa) + " (" + front_state() + ")";
            hand_over_stall(xa, 8.0, why);
            FrontStall stall(why, xa, __FILE__, __LINE__, __func__);
            stall.add_earlier_places(abandoned_);
            throw stall;
        } else if (!local_remesh(top.edge)) {
            // Nothing to remove around the edge (e.g. a loop edge at a sharp corner
            // before any triangle): the last resort, then any valid closing of its loop.
            if (advance(top.edge, 2) || close_small_loop(top.edge, 0.0)) {
                ++last_resort_;
                continue;
            }
            // Put back behind every fresh edge a few times: the front around may open
            // the way.
            FrontEdge& stuck = edges_[static_cast<std::size_t>(top.edge)];
            if (stuck.stalls < 3) {
                ++stuck.stalls;
                stuck.fails = 1;
                queue_.push({1, top.length, top.edge});
                continue;
            }
            const Eigen::Vector3d& xa = xyz_[static_cast<std::size_t>(stuck.a)];
            const std::string why = "remesh: the front cannot advance from edge at " + where(xa) +
                                    " and there is nothing to remesh around it";
            abandon(xa, 8.0, why);  // the edge is not queued again
        }
    }
    if (front_size_ > 0 && !abandoned_.empty()) {
        // Every place where the front was given up, found in this one attempt. Edges wait
        // only at such places, so a front left means at least one place.
        const Eigen::Vector3d last = abandoned_.back();
        abandoned_.pop_back();
        FrontStall stall(first_abandoned_why_ + " (and " + std::to_string(abandoned_.size()) +
                             " more place(s) in this patch)",
                         last, __FILE__, __LINE__, __func__);
        stall.add_earlier_places(abandoned_);
        throw stall;
    }
    FM_CHECK(front_size_ == 0);
    static const char* const reasons[11] = {
        "normal",   "side",       "sector",     "mesh_edge", "sector_apex", "point_inside",
        "crossing", "projection", "near_point", "near_edge", "crossing_3d"};
    for (int i = 0; i < 11; ++i)
        ctx_.add(std::string("remesh.front_rejected_") + reasons[i], static_cast<double>(why_[i]));
    ctx_.add("remesh.front_local_remeshings", static_cast<double>(remeshings_));
    ctx_.add("remesh.front_closed_loops", static_cast<double>(closed_loops_));
    ctx_.add("remesh.front_last_resort_triangles", static_cast<double>(last_resort_));
    ctx_.add("remesh.front_steps", static_cast<double>(steps));

    if (params_.smoothing_iterations > 0) smooth();

    // Compact: loop points keep their ids (they come first and are never removed).
    PatchMesh out;
    std::vector<std::int32_t> new_id(xyz_.size(), -1);
    for (std::size_t p = 0; p < xyz_.size(); ++p) {
        if (!alive_[p]) continue;
        new_id[p] = static_cast<std::int32_t>(out.points.size());
        out.points.push_back(xyz_[p]);
        out.point_face.push_back(face_[p]);
    }
    for (std::size_t t = 0; t < tris_.size(); ++t) {
        if (!tri_alive_[t]) continue;
        const auto& tri = tris_[t];
        out.faces.push_back({new_id[static_cast<std::size_t>(tri[0])],
                             new_id[static_cast<std::size_t>(tri[1])],
                             new_id[static_cast<std::size_t>(tri[2])]});
        FM_CHECK(out.faces.back()[0] >= 0 && out.faces.back()[1] >= 0 && out.faces.back()[2] >= 0);
    }
    return out;
}

// Smoothing inside the patch: each free point moves toward the centroid of its neighbours,
// projected back onto the background from its face; the move is kept only when the smallest
// angle of its triangles grows and their orientation stays consistent with the background.
void FrontMesher::smooth() {
    std::vector<std::int32_t> ring;
    for (int it = 0; it < params_.smoothing_iterations; ++it) {
        for (std::size_t p = 0; p < xyz_.size(); ++p) {
            if (!alive_[p] || fixed_[p]) continue;
            Eigen::Vector3d sum = Eigen::Vector3d::Zero();
            int count = 0;
            double before = 180.0;
            for (std::int32_t s = tri_head_[p]; s >= 0;
                 s = tri_next_[static_cast<std::size_t>(s)]) {
                const auto& t = tris_[static_cast<std::size_t>(s / 3)];
                sum += xyz_[static_cast<std::size_t>(t[static_cast<std::size_t>((s % 3 + 1) % 3)])];
                ++count;
                before = std::min(
                    before, core::triangle_min_angle_deg(xyz_[static_cast<std::size_t>(t[0])],
                                                         xyz_[static_cast<std::size_t>(t[1])],
                                                         xyz_[static_cast<std::size_t>(t[2])]));
            }
            if (count < 3) continue;
            const BackgroundPatch::Projection pr = patch_.project(sum / count, face_[p]);
            const Eigen::Vector3d old = xyz_[p];
            xyz_[p] = pr.point;
            double after = 180.0;
            bool ok = true;
            const Eigen::Vector3d np = patch_.smooth_normal(pr.face);
            for (std::int32_t s = tri_head_[p]; s >= 0 && ok;
                 s = tri_next_[static_cast<std::size_t>(s)]) {
                const auto& t = tris_[static_cast<std::size_t>(s / 3)];
                const Eigen::Vector3d& x0 = xyz_[static_cast<std::size_t>(t[0])];
                const Eigen::Vector3d& x1 = xyz_[static_cast<std::size_t>(t[1])];
                const Eigen::Vector3d& x2 = xyz_[static_cast<std::size_t>(t[2])];
                const Eigen::Vector3d tn = (x1 - x0).cross(x2 - x0);
                if (tn.dot(np) <= 0.3 * tn.norm()) ok = false;
                after = std::min(after, core::triangle_min_angle_deg(x0, x1, x2));
            }
            if (ok && after > before) {
                face_[p] = pr.face;
                normal_[p] = np;
            } else {
                xyz_[p] = old;
            }
        }
    }
}

// A patch whose front cannot be closed starts again with all sizes scaled by this per failed
// attempt (FrontParams::attempts): the last of the size multipliers listed beside the remesh
// stage's RetryPolicy (surface/remesh_internal.h).
constexpr double kAttemptScale = 0.85;

}  // namespace front_detail

PatchMesh triangulate_patch(const BackgroundPatch& patch, const std::vector<PatchLoop>& loops,
                            const SizeFunction& size, const FrontParams& params,
                            core::StageContext& ctx) {
    if (params.max_local_remesh < 1)
        FM_THROW(InputError, "remesh: max_local_remesh must be at least 1");
    if (params.smoothing_iterations < 0)
        FM_THROW(InputError, "remesh: smoothing_iterations must not be negative");
    if (params.attempts < 1) FM_THROW(InputError, "remesh: attempts must be at least 1");
    std::vector<Eigen::Vector3d> stalled_at;  // the places of the failed attempts
    for (int attempt = 0;; ++attempt) {
        const double scale = std::pow(front_detail::kAttemptScale, attempt);
        const SizeFunction scaled = [&size, scale](const Eigen::Vector3d& p, std::int32_t face) {
            return scale * size(p, face);
        };
        try {
            // The mesher's own context: diagnostics and cancellation of the caller's, its
            // counters kept only when the attempt succeeds.
            core::StageContext sub = ctx.child();
            front_detail::FrontMesher mesher(patch, attempt == 0 ? size : scaled, params, sub,
                                             attempt);
            PatchMesh mesh = mesher.run(loops);
            ctx.merge_from(sub);
            ctx.add("remesh.patch_retries", attempt);
            return mesh;
        } catch (FrontStall& e) {
            // Given up at several places, the front closed everywhere else: what fails is the
            // geometry there, not the attempt's seed or scale, and another attempt would
            // cost the whole patch again; the stage shrinks or cuts at every place instead.
            constexpr std::size_t kPlacesForNoRetry = 3;
            if (attempt + 1 >= params.attempts || e.places().size() >= kPlacesForNoRetry) {
                e.add_earlier_places(stalled_at);
                throw;
            }
            stalled_at.push_back(e.place());
            ctx.warn(std::string(e.what()) + "; the patch starts again with sizes x " +
                     std::to_string(std::pow(front_detail::kAttemptScale, attempt + 1)));
        }
    }
}

}  // namespace frontmesh::surface
