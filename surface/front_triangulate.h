#pragma once
// Direct advancing-front triangulation of one surface patch over the discrete background
// surface (paper §2): new points are placed at the target size over front edges and projected
// onto the background (closest point through an ADT over background triangles).
// Implementation: BackgroundPatch in surface/background_patch.cpp; the front in
// surface/front_triangulate.cpp, front_step.cpp and front_stall.cpp (file map in
// surface/front_mesher.h).

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/error.h"
#include "pipeline/core/stage_context.h"
#include "pipeline/core/surface_network.h"

namespace frontmesh::surface {

/// One patch of the background: a set of its triangles, oriented as the output must be, with
/// closest-point projection (ADT over triangle boxes).
class BackgroundPatch {
public:
    /// `faces`: ids into background.faces of one connected patch. When `flip` is set the patch
    /// is used with reversed orientation. `background` must outlive the object.
    BackgroundPatch(const core::SurfaceNetwork& background, std::vector<std::int32_t> faces,
                    bool flip);
    ~BackgroundPatch();
    BackgroundPatch(BackgroundPatch&&) noexcept;
    BackgroundPatch& operator=(BackgroundPatch&&) noexcept;

    struct Projection {
        Eigen::Vector3d point;   ///< closest point on the patch's triangles
        std::int32_t face = -1;  ///< background face id holding it
        double distance = 0.0;   ///< mm
    };
    /// Closest point of the patch to `p` (exact over all patch triangles: nearest box in the
    /// ADT, then every box within that triangle's distance). Cost O(log n) typical.
    Projection project(const Eigen::Vector3d& p) const;
    /// Closest point found by a local descent over the patch starting at background face
    /// `hint` (a face of this patch, else the global search is used): moves to the closest
    /// face among those sharing a vertex with the current one until none is closer. Stays on
    /// the sheet of `hint` across thin gaps; a local (not always global) closest point.
    /// Cost O(steps x 13) point-triangle distances; falls back to project(p) after 64 steps.
    Projection project(const Eigen::Vector3d& p, std::int32_t hint) const;
    /// Closest point among the patch faces within `radius` (mm) of `p` whose normal n_f
    /// satisfies n_f . `normal` >= `min_cos` (thin gaps: the other sheet faces the other
    /// way); nullopt when none qualifies.
    std::optional<Projection> project_oriented(const Eigen::Vector3d& p,
                                               const Eigen::Vector3d& normal, double radius,
                                               double min_cos) const;
    /// Unit normal of background face `face` with the patch's orientation.
    Eigen::Vector3d normal(std::int32_t face) const;
    /// Area-weighted mean of the unit normals of the patch faces sharing a vertex with
    /// `face` (precomputed): a steadier direction than normal(face) on a staircase
    /// background. Unit length.
    Eigen::Vector3d smooth_normal(std::int32_t face) const;
    const std::vector<std::int32_t>& faces() const;
    const core::SurfaceNetwork& background() const;
    /// Upper bound (mm) of the distance along the patch from `p` on face `face_p` to `q` on
    /// face `face_q` (shortest path over patch edges, entered and left straight from the
    /// points), or infinity when it exceeds `limit`. Tells a fold or ridge (short way round)
    /// from a thin gap (long way round). Cost: Dijkstra over the vertices within `limit`.
    double path_distance(const Eigen::Vector3d& p, std::int32_t face_p, const Eigen::Vector3d& q,
                         std::int32_t face_q, double limit) const;
    /// True when background face `face` belongs to the patch.
    bool contains(std::int32_t face) const;
    /// Total area of the patch triangles, mm^2.
    double area() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Target edge length (mm) at a point on the background; `face` is the background face the
/// point lies on (a hint for fast lookup).
using SizeFunction = std::function<double(const Eigen::Vector3d& p, std::int32_t face)>;

/// A closed boundary loop of a patch: consecutive points (and last → first) are edges that
/// must appear unchanged in the output. Runs counter-clockwise around the patch seen from the
/// side its normal points to (the patch lies to the left of each edge).
struct PatchLoop {
    std::vector<Eigen::Vector3d> points;
};

struct FrontParams {
    /// Smoothing passes inside the patch after the front closes (0: none): each free point
    /// moves to the centroid of its neighbours, projected onto the background, kept only when
    /// the smallest angle of its triangles grows. Loop points never move.
    int smoothing_iterations = 0;
    /// Local remeshings within two edge lengths of one place before MeshingError (the removed
    /// region grows with each). With n = area / (0.43 h_min^2) + loop points, the whole patch
    /// also stops after n / 20 + 20 remeshings, 20 n + 400 steps or 4 n + 64 live triangles
    /// (work proportional to the patch, front_triangulate.cpp).
    int max_local_remesh = 50;
    /// Attempts per patch: when the front cannot be closed, the patch starts again with the
    /// sizes scaled by 0.85 (and, without loops, from another seed face). >= 1.
    int attempts = 4;
};

/// The triangulated patch. points: the loop points first (loops in input order, each in
/// loop order), then interior points; faces' right-hand normals agree with the patch
/// orientation; point_face: the background face each point lies on.
struct PatchMesh {
    std::vector<Eigen::Vector3d> points;
    std::vector<std::array<std::int32_t, 3>> faces;
    std::vector<std::int32_t> point_face;
};

/// The front of a patch cannot be closed: a MeshingError that also carries the place (mm),
/// so that the caller can mesh the place again finer.
class FrontStall : public core::MeshingError {
public:
    FrontStall(const std::string& message, const Eigen::Vector3d& place, const char* file = "",
               int line = 0, const char* function = "")
        : core::MeshingError(message, file, line, function), place_(place) {}
    const Eigen::Vector3d& place() const { return place_; }
    /// Every place where an attempt of the patch stalled (triangulate_patch's attempts start
    /// from other seeds and sizes, so they often stall at different places), place() last.
    std::vector<Eigen::Vector3d> places() const {
        std::vector<Eigen::Vector3d> all = earlier_;
        all.push_back(place_);
        return all;
    }
    void add_earlier_places(const std::vector<Eigen::Vector3d>& places) {
        earlier_.insert(earlier_.begin(), places.begin(), places.end());
    }

private:
    Eigen::Vector3d place_;
    std::vector<Eigen::Vector3d> earlier_;
};

/// Triangulates the patch from its boundary loops inward (a patch without loops, e.g. a
/// closed surface, starts from a seed triangle and advances until the front closes). Every
/// loop edge is an edge of exactly one output face; interior points lie on the background.
/// Throws FrontStall naming the place when the front cannot be closed.
PatchMesh triangulate_patch(const BackgroundPatch& patch, const std::vector<PatchLoop>& loops,
                            const SizeFunction& size, const FrontParams& params,
                            core::StageContext& ctx);

}  // namespace frontmesh::surface
