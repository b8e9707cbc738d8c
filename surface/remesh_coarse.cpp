// Coarse patches of the remesh stage (issue 20): a closed shell smaller than the size field
// allows (a label island of a few voxels, thinner than the smallest edge) cannot be met by an
// advancing front, whose tangent-plane tests need room for a triangle of the target size on
// every side. Such a patch is meshed by the coarsest valid triangulation of its background
// that keeps its shape: its own triangles with edges collapsed shortest first, every point a
// background vertex. The same coarsening mends the patches that keep their background
// triangles after repeated stalls (their loop points fixed).

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <limits>
#include <optional>
#include <queue>
#include <tuple>

#include "pipeline/core/adt.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "surface/front_internal.h"
#include "surface/remesh_internal.h"

namespace frontmesh::surface::remesh_detail {

namespace {

// Collapses must keep the worst angle of the faces they touch, or at least this (degrees).
constexpr double kKeepAngleDeg = 25.0;
// A removed point stays within this fraction of the local size of the new faces, summed over
// the collapses that made them.
constexpr double kMaxDeviation = 0.1;
// A closed patch keeps its enclosed volume within this fraction (sum of |change| over the
// collapses).
constexpr double kMaxVolumeChange = 0.02;
// Edges longer than this times h are split first; no collapse makes one.
constexpr double kSplitAbove = 4.0 / 3.0;
// Light: a collapse may make the worst angle at u this much smaller (each collapse removes a
// point, so a cluster of needles shrinks to one point; the smoothing after mends the angles).
constexpr double kLightKeepAngle = 0.5;
// A face with a smaller angle than this (degrees) is a needle: its normal is noise.
constexpr double kNeedleDeg = 1.0;
// A collapse may not leave the kept point with more neighbours than this.
constexpr std::size_t kMaxValence = 12;

double signed_volume6(const Eigen::Vector3d& o, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      const Eigen::Vector3d& c) {
    return (a - o).dot((b - o).cross(c - o));
}

// Edge collapse on one patch mesh. Points never move: every point stays a background vertex.
class Coarsener {
public:
    Coarsener(const BackgroundPatch& patch, PatchMesh mesh, std::size_t fixed,
              const SizeFunction& size, double collapse_below)
        : patch_(patch),
          size_(size),
          collapse_below_(collapse_below),
          mesh_(std::move(mesh)),
          fixed_(fixed),
          boxes_(domain(mesh_), core::AdtItems::boxes) {
        const std::size_t np = mesh_.points.size(), nf = mesh_.faces.size();
        point_alive_.assign(np, 0);
        face_alive_.assign(nf, 1);
        error_.assign(nf, 0.0);
        point_faces_.resize(np);
        for (std::size_t f = 0; f < nf; ++f) {
            for (const std::int32_t v : mesh_.faces[f]) {
                point_faces_[std::size_t(v)].push_back(std::int32_t(f));
                point_alive_[std::size_t(v)] = 1;
            }
            boxes_.insert(std::int32_t(f), box_of(mesh_.faces[f]));
        }
        alive_points_ = std::size_t(std::count(point_alive_.begin(), point_alive_.end(), 1));
        closed_ = fixed_ == 0;  // a patch without loops is a closed surface
        if (closed_) {
            volume6_ = 0.0;
            const Eigen::Vector3d o = x(mesh_.faces.front()[0]);
            for (const auto& t : mesh_.faces)
                volume6_ += signed_volume6(o, x(t[0]), x(t[1]), x(t[2]));
        }
    }

    // Collapses edges shortest first while one is valid (collapse()). Ends: every collapse
    // removes a point (at most points - 4 of them); an edge is queued once at the start and
    // again only when a collapse changes the faces at one of its ends (at most the edges
    // within one ring of the kept point, <= (kMaxValence + 1) * max valence per collapse),
    // and each queue entry is popped once.
    PatchMesh run() {
        if (!(collapse_below_ < kSplitAbove)) split_long_edges();
        for (std::size_t f = 0; f < mesh_.faces.size(); ++f)
            for (int k = 0; k < 3; ++k)
                push(mesh_.faces[f][std::size_t(k)], mesh_.faces[f][std::size_t((k + 1) % 3)]);
        while (!queue_.empty()) {
            const auto [length, u, v] = queue_.top();
            queue_.pop();
            if (!point_alive_[std::size_t(u)] || !point_alive_[std::size_t(v)]) continue;
            std::optional<Plan> best;
            for (const auto& [from, to] : {std::pair{u, v}, std::pair{v, u}}) {
                std::optional<Plan> plan = plan_collapse(from, to);
                if (plan && (!best || plan->min_angle > best->min_angle)) best = std::move(plan);
            }
            if (best) apply(*best);
        }
        return compacted();
    }

private:
    // Splits edges longer than kSplitAbove h at their midpoint projected onto the background,
    // longest first, where the four new faces face the background's way and overlap no other
    // face (a background coarser than h: a one-voxel bridge of 0.2 x 0.2 mm section and 1 mm
    // voxels). Boundary edges (one face: loop edges) never split. Ends: at most 4 x the
    // initial faces splits (a count bound), each queueing at most its 4 new edges.
    void split_long_edges() {
        const std::size_t max_splits = 4 * mesh_.faces.size();
        std::priority_queue<Entry> longest;
        auto push_long = [&](std::int32_t a, std::int32_t b) {
            if (a > b) std::swap(a, b);
            const double length = (x(a) - x(b)).norm();
            if (length > kSplitAbove * size_at(0.5 * (x(a) + x(b)), a))
                longest.emplace(length, a, b);
        };
        for (const auto& t : mesh_.faces)
            for (int k = 0; k < 3; ++k) push_long(t[std::size_t(k)], t[std::size_t((k + 1) % 3)]);
        std::size_t splits = 0;
        while (!longest.empty() && splits < max_splits) {
            const auto [length, a, b] = longest.top();
            longest.pop();
            const std::optional<std::int32_t> m = split(a, b);
            if (!m) continue;
            ++splits;
            for (const std::int32_t w : neighbours(*m)) push_long(*m, w);
        }
    }

    // Splits edge ab at the background point nearest its midpoint; the new point, or nullopt
    // when the edge is not an inner edge or a new face would be invalid.
    std::optional<std::int32_t> split(std::int32_t a, std::int32_t b) {
        std::vector<std::int32_t> both;  // the faces holding edge ab
        for (const std::int32_t f : point_faces_[std::size_t(a)]) {
            const auto& t = mesh_.faces[std::size_t(f)];
            if (t[0] == b || t[1] == b || t[2] == b) both.push_back(f);
        }
        if (both.size() != 2) return std::nullopt;
        const BackgroundPatch::Projection pr =
            patch_.project(0.5 * (x(a) + x(b)), mesh_.point_face[std::size_t(a)]);
        const Eigen::Vector3d& xm = pr.point;
        // Each old face (p, q, r) with edge ab becomes two: the corner a or b replaced by m.
        std::vector<std::array<std::int32_t, 3>> added;
        const auto m = std::int32_t(mesh_.points.size());
        for (const std::int32_t f : both)
            for (const std::int32_t end : {a, b}) {
                std::array<std::int32_t, 3> t = mesh_.faces[std::size_t(f)];
                for (auto& w : t)
                    if (w == end) w = m;
                added.push_back(t);
            }
        auto point = [&](std::int32_t v) -> const Eigen::Vector3d& { return v == m ? xm : x(v); };
        for (std::size_t k = 0; k < added.size(); ++k) {
            const auto& t = added[k];
            const Eigen::Vector3d &p = point(t[0]), &q = point(t[1]), &r = point(t[2]);
            const Eigen::Vector3d n = (q - p).cross(r - p);
            const double nl = n.norm();
            const auto& o = mesh_.faces[std::size_t(both[k / 2])];
            const Eigen::Vector3d no = (x(o[1]) - x(o[0])).cross(x(o[2]) - x(o[0]));
            if (!(nl > 0.0) || n.dot(no) <= 0.2 * nl * no.norm()) return std::nullopt;
            const BackgroundPatch::Projection under = patch_.project((p + q + r) / 3.0, pr.face);
            if (n.dot(patch_.smooth_normal(under.face)) <= 0.2 * nl) return std::nullopt;
            const double* xt[3] = {p.data(), q.data(), r.data()};
            core::AdtBox box = core::AdtBox::of_point(p);
            box.extend(q);
            box.extend(r);
            boxes_.query_box(box, hits_);
            for (const std::int32_t g : hits_) {
                if (g == both[0] || g == both[1]) continue;
                const auto& og = mesh_.faces[std::size_t(g)];
                const double* xo[3] = {x(og[0]).data(), x(og[1]).data(), x(og[2]).data()};
                if (triangles_overlap(t.data(), xt, og.data(), xo)) return std::nullopt;
            }
        }
        mesh_.points.push_back(xm);
        mesh_.point_face.push_back(pr.face);
        point_alive_.push_back(1);
        point_faces_.emplace_back();
        ++alive_points_;
        const double error = std::max(error_[std::size_t(both[0])], error_[std::size_t(both[1])]);
        Plan plan;
        plan.removed = both;
        plan.added = added;
        plan.added_error.assign(added.size(), error);
        replace_faces(plan);
        return m;
    }

    struct Plan {
        std::int32_t u = -1, v = -1;                     // u goes, v stays
        std::vector<std::int32_t> removed;               // faces at u
        std::vector<std::array<std::int32_t, 3>> added;  // faces at u not at v, u -> v
        std::vector<double> added_error;
        double min_angle = 0.0;
        double volume6_change = 0.0;
    };
    using Entry = std::tuple<double, std::int32_t, std::int32_t>;

    static core::AdtBox domain(const PatchMesh& mesh) {
        core::AdtBox box;
        for (const Eigen::Vector3d& p : mesh.points) box.extend(p);
        return box.enlarged(1e-3 * std::max(1.0, (box.hi - box.lo).norm()));
    }
    const Eigen::Vector3d& x(std::int32_t v) const { return mesh_.points[std::size_t(v)]; }
    core::AdtBox box_of(const std::array<std::int32_t, 3>& t) const {
        core::AdtBox box = core::AdtBox::of_point(x(t[0]));
        box.extend(x(t[1]));
        box.extend(x(t[2]));
        return box;
    }
    // Light: only edges shorter than collapse_below x the longest edge at their ends.
    void push(std::int32_t a, std::int32_t b) {
        if (a > b) std::swap(a, b);
        const double length = (x(a) - x(b)).norm();
        if (collapse_below_ < kSplitAbove &&
            !(length < collapse_below_ * std::max(longest_edge_at(a), longest_edge_at(b))))
            return;
        queue_.emplace(length, a, b);
    }
    double longest_edge_at(std::int32_t v) const {
        double longest = 0.0;
        for (const std::int32_t f : point_faces_[std::size_t(v)]) {
            const auto& t = mesh_.faces[std::size_t(f)];
            for (int e = 0; e < 3; ++e)
                longest = std::max(longest,
                                   (x(t[std::size_t(e)]) - x(t[std::size_t((e + 1) % 3)])).norm());
        }
        return longest;
    }
    std::vector<std::int32_t> neighbours(std::int32_t v) const {
        std::vector<std::int32_t> n;
        for (const std::int32_t f : point_faces_[std::size_t(v)])
            for (const std::int32_t w : mesh_.faces[std::size_t(f)])
                if (w != v) n.push_back(w);
        std::sort(n.begin(), n.end());
        n.erase(std::unique(n.begin(), n.end()), n.end());
        return n;
    }
    double size_at(const Eigen::Vector3d& p, std::int32_t v) const {
        return size_(p, mesh_.point_face[std::size_t(v)]);
    }

    // Collapse of u into v, or nullopt when it would break the patch: u fixed (a loop point),
    // the link condition (the common neighbours of u and v are exactly the far corners of
    // their two faces, so the result stays a 2-manifold), a closed patch down to 4 points,
    // a new face degenerate, turned against its old face or the background under it, worse in
    // angle than min(kept, kKeepAngleDeg), with an edge longer than kSplitAbove h, overlapping
    // another face, or u farther from the new faces than kMaxDeviation h; and the volume.
    std::optional<Plan> plan_collapse(std::int32_t u, std::int32_t v) const {
        if (std::size_t(u) < fixed_) return std::nullopt;
        if (closed_ && alive_points_ <= 4) return std::nullopt;
        Plan plan;
        plan.u = u;
        plan.v = v;
        std::vector<std::int32_t> far;  // far corners of the faces holding edge uv
        double old_angle = 180.0, old_error = 0.0;
        for (const std::int32_t f : point_faces_[std::size_t(u)]) {
            const auto& t = mesh_.faces[std::size_t(f)];
            plan.removed.push_back(f);
            old_angle =
                std::min(old_angle, core::triangle_min_angle_deg(x(t[0]), x(t[1]), x(t[2])));
            old_error = std::max(old_error, error_[std::size_t(f)]);
            if (t[0] == v || t[1] == v || t[2] == v) {
                for (const std::int32_t w : t)
                    if (w != u && w != v) far.push_back(w);
                continue;
            }
            std::array<std::int32_t, 3> n = t;
            for (auto& w : n)
                if (w == u) w = v;
            plan.added.push_back(n);
        }
        if (far.size() != 2 || far[0] == far[1]) return std::nullopt;
        const std::vector<std::int32_t> nu = neighbours(u), nv = neighbours(v);
        std::vector<std::int32_t> common;
        std::set_intersection(nu.begin(), nu.end(), nv.begin(), nv.end(),
                              std::back_inserter(common));
        std::sort(far.begin(), far.end());
        if (common != far) return std::nullopt;
        if (nu.size() + nv.size() - 4 > kMaxValence) return std::nullopt;

        const Eigen::Vector3d& xu = x(u);
        // Light (a copied patch beside others): the scale is the longest edge at u, and no
        // new edge is longer; else h.
        const bool light = collapse_below_ < kSplitAbove;
        const double h = light ? longest_edge_at(u) : size_at(xu, u);
        double deviation = std::numeric_limits<double>::infinity();
        plan.min_angle = 180.0;
        for (std::size_t k = 0; k < plan.added.size(); ++k) {
            const auto& t = plan.added[k];
            const Eigen::Vector3d &a = x(t[0]), &b = x(t[1]), &c = x(t[2]);
            const Eigen::Vector3d n = (b - a).cross(c - a);
            const double nl = n.norm();
            if (!(nl > 0.0)) return std::nullopt;
            // The old face: the same corners with u in place of v.
            std::array<std::int32_t, 3> o = t;
            for (auto& w : o)
                if (w == v) w = u;
            // It keeps its side against its old face and the background's smoothed normal;
            // light, the old face alone decides unless it was a needle (its normal is noise,
            // and at a marching-cubes corner the smoothed normal is too).
            const Eigen::Vector3d no = (x(o[1]) - x(o[0])).cross(x(o[2]) - x(o[0]));
            const bool needle =
                core::triangle_min_angle_deg(x(o[0]), x(o[1]), x(o[2])) <= kNeedleDeg;
            if ((!needle || !light) && n.dot(no) <= 0.2 * nl * no.norm()) return std::nullopt;
            const BackgroundPatch::Projection pr =
                patch_.project((a + b + c) / 3.0, mesh_.point_face[std::size_t(v)]);
            if ((needle || !light) && n.dot(patch_.smooth_normal(pr.face)) <= 0.2 * nl)
                return std::nullopt;
            plan.min_angle = std::min(plan.min_angle, core::triangle_min_angle_deg(a, b, c));
            for (int e = 0; e < 3; ++e) {
                const Eigen::Vector3d& p = x(t[std::size_t(e)]);
                const Eigen::Vector3d& q = x(t[std::size_t((e + 1) % 3)]);
                if ((p - q).norm() >
                    (light ? (1.0 + collapse_below_) * h
                           : kSplitAbove * size_at(0.5 * (p + q), t[std::size_t(e)])))
                    return std::nullopt;
            }
            deviation = std::min(deviation, (closest_point_on_triangle(xu, a, b, c) - xu).norm());
        }
        if (plan.added.empty()) return std::nullopt;
        if (plan.min_angle < (light ? kLightKeepAngle : 1.0) * std::min(old_angle, kKeepAngleDeg))
            return std::nullopt;
        const double error = old_error + deviation;
        if (error > kMaxDeviation * h) return std::nullopt;
        plan.added_error.assign(plan.added.size(), error);
        // Volume between the old and the new surface: the faces at u seen from v (the new
        // faces all hold v and add nothing).
        for (const std::int32_t f : plan.removed) {
            const auto& t = mesh_.faces[std::size_t(f)];
            plan.volume6_change -= signed_volume6(x(v), x(t[0]), x(t[1]), x(t[2]));
        }
        if (closed_ && std::abs(volume6_changed_) + std::abs(plan.volume6_change) >
                           kMaxVolumeChange * std::abs(volume6_))
            return std::nullopt;
        // No overlap with the faces that stay.
        for (const auto& t : plan.added) {
            const double* xt[3] = {x(t[0]).data(), x(t[1]).data(), x(t[2]).data()};
            boxes_.query_box(box_of(t), hits_);
            for (const std::int32_t g : hits_) {
                if (std::find(plan.removed.begin(), plan.removed.end(), g) != plan.removed.end())
                    continue;
                const auto& o = mesh_.faces[std::size_t(g)];
                const double* xo[3] = {x(o[0]).data(), x(o[1]).data(), x(o[2]).data()};
                if (triangles_overlap(t.data(), xt, o.data(), xo)) return std::nullopt;
            }
        }
        return plan;
    }

    void apply(const Plan& plan) {
        replace_faces(plan);
        point_alive_[std::size_t(plan.u)] = 0;
        --alive_points_;
        volume6_changed_ += std::abs(plan.volume6_change);
        // The faces changed at v and its neighbours: their edges may collapse now.
        for (const std::int32_t w : neighbours(plan.v)) {
            push(plan.v, w);
            for (const std::int32_t z : neighbours(w)) push(w, z);
        }
    }

    // The plan's removed faces out, its added faces in (incidences and boxes kept).
    void replace_faces(const Plan& plan) {
        for (const std::int32_t f : plan.removed) {
            face_alive_[std::size_t(f)] = 0;
            boxes_.remove(f);
            for (const std::int32_t w : mesh_.faces[std::size_t(f)]) {
                auto& at = point_faces_[std::size_t(w)];
                at.erase(std::remove(at.begin(), at.end(), f), at.end());
            }
        }
        for (std::size_t k = 0; k < plan.added.size(); ++k) {
            const auto f = std::int32_t(mesh_.faces.size());
            mesh_.faces.push_back(plan.added[k]);
            face_alive_.push_back(1);
            error_.push_back(plan.added_error[k]);
            for (const std::int32_t w : plan.added[k]) point_faces_[std::size_t(w)].push_back(f);
            boxes_.insert(f, box_of(plan.added[k]));
        }
    }

    // Loop points keep their ids (the first `fixed_`, used or not); the rest in order.
    PatchMesh compacted() const {
        PatchMesh out;
        std::vector<std::int32_t> id(mesh_.points.size(), -1);
        for (std::size_t p = 0; p < mesh_.points.size(); ++p) {
            if (p >= fixed_ && !point_alive_[p]) continue;
            id[p] = std::int32_t(out.points.size());
            out.points.push_back(mesh_.points[p]);
            out.point_face.push_back(mesh_.point_face[p]);
        }
        for (std::size_t f = 0; f < mesh_.faces.size(); ++f) {
            if (!face_alive_[f]) continue;
            const auto& t = mesh_.faces[f];
            out.faces.push_back(
                {id[std::size_t(t[0])], id[std::size_t(t[1])], id[std::size_t(t[2])]});
            FM_CHECK(out.faces.back()[0] >= 0 && out.faces.back()[1] >= 0 &&
                     out.faces.back()[2] >= 0);
        }
        return out;
    }

    const BackgroundPatch& patch_;
    const SizeFunction& size_;
    double collapse_below_;
    PatchMesh mesh_;
    std::size_t fixed_;
    bool closed_ = false;
    core::Adt boxes_;  // live faces
    mutable std::vector<std::int32_t> hits_;
    std::vector<std::uint8_t> point_alive_, face_alive_;
    std::vector<double> error_;  // per face: deviation of the points removed under it, mm
    std::vector<std::vector<std::int32_t>> point_faces_;
    std::size_t alive_points_ = 0;
    double volume6_ = 0.0, volume6_changed_ = 0.0;  // six times the volumes
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue_;
};

}  // namespace

bool is_small_closed_patch(const BackgroundPatch& patch, const SizeFunction& size,
                           double nominal_h) {
    const core::SurfaceNetwork& bg = patch.background();
    double h_max = nominal_h;
    core::AdtBox box;
    for (const std::int32_t f : patch.faces()) {
        const auto& t = bg.faces[std::size_t(f)];
        h_max = std::max(h_max, size((bg.point(t[0]) + bg.point(t[1]) + bg.point(t[2])) / 3.0, f));
        for (const std::int32_t v : t) box.extend(bg.point(v));
    }
    return box.is_valid() && (box.hi - box.lo).norm() < 2.0 * h_max;
}

PatchMesh coarsen_patch(const BackgroundPatch& patch, PatchMesh mesh, std::size_t fixed_points,
                        const SizeFunction& size, double collapse_below) {
    FM_CHECK(fixed_points <= mesh.points.size() && !mesh.faces.empty());
    return Coarsener(patch, std::move(mesh), fixed_points, size, collapse_below).run();
}

}  // namespace frontmesh::surface::remesh_detail
