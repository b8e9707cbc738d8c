#pragma once
// Angle-based smoothing (T. Zhou and K. Shimada, IMR 2000) and edge flips of a remeshed
// surface network, with every vertex kept on the background surface (paper §2: "an
// angle-based smoothing method is applied to the resulting mesh to ensure quality").

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/stage_context.h"
#include "pipeline/core/surface_network.h"
#include "surface/front_triangulate.h"

namespace frontmesh::surface {

/// A discretised feature curve of the output: output vertices along a background polyline.
struct SurfaceCurve {
    std::vector<Eigen::Vector3d> polyline;  ///< background polyline (closed: last == first)
    std::vector<std::int32_t> vertices;     ///< output vertices along it (closed: last == first)
    std::vector<double> s;                  ///< arc length (mm) of each vertex on the polyline
    bool is_closed = false;  ///< no corner: its first vertex slides too (arc length wraps)
};

/// What each output vertex may do. Vertices on no curve are free: they move on the patch of
/// their faces. Interior curve vertices slide along their curve; curve ends (corners) stay.
struct SurfaceConstraints {
    std::vector<std::int32_t> face_patch;   ///< per output face: index into the patch list
    std::vector<std::int32_t> vertex_face;  ///< per output vertex: background face hint, or -1
    std::vector<SurfaceCurve> curves;
};

struct SmoothingParams {
    int iterations = 5;                   ///< smoothing + flip passes
    bool flip_edges = true;               ///< edge flips inside patches
    double flip_max_dihedral_deg = 10.0;  ///< only flip edges whose two faces are this flat
    /// A move is refused when a face's normal turns by more than this (degrees): no folds.
    double max_normal_turn_deg = 30.0;
    /// Region wedges (interior dihedral angle of a region between its two faces at a junction
    /// edge) under this are raised by a last pass of moves and flips, and no move or flip may
    /// lower one under min(this, 20); 0 = off (no guard either).
    double wedge_target_deg = 20.0;
    /// Forced tets (ForcedTet) whose smallest dihedral angle is under this are raised by a
    /// last pass of moves (fans with a wedge under twice this count); 0 = off.
    double tip_target_deg = 20.0;
    /// Region wedges and forced tets still under their targets after those passes, where the
    /// background itself is that thin, are raised by moves of vertices (not corners) off
    /// the background (at most 0.15 of the local edge): the last pass.
    bool open_thin_wedges = true;
};

struct SmoothingReport {
    std::size_t moves = 0;  ///< accepted vertex moves, all passes
    std::size_t flips = 0;  ///< accepted edge flips, all passes
    double min_angle_before_deg = 0.0;
    double min_angle_after_deg = 0.0;
    std::size_t wedge_changes = 0;           ///< moves + flips of the wedge passes
    double min_wedge_before_deg = 0.0;       ///< smallest region wedge before the wedge passes
    double min_wedge_after_deg = 0.0;        ///< and after (360 when there is no junction edge)
    std::size_t tip_changes = 0;             ///< moves of the tip passes
    double min_forced_tet_before_deg = 0.0;  ///< smallest ForcedTet angle before the tip passes
    double min_forced_tet_after_deg = 0.0;   ///< and after (180 when there is none)
    std::size_t openings = 0;                ///< moves off the background (open_thin_wedges)
};

/// A junction edge (three or more faces) where a region's wedge, the interior dihedral angle
/// between its two faces there, is small: every tetrahedron of the region on that edge has a
/// dihedral angle no larger.
struct ThinWedge {
    Eigen::Vector3d midpoint;         ///< of the edge
    double wedge_deg = 0.0;           ///< the smallest region wedge there
    std::vector<std::int32_t> faces;  ///< the faces at the edge, increasing
};

/// Junction edges of `surface` with a region wedge under `below_deg`, in edge order. A wedge w
/// counts as min(w, 360 - w): two faces lying on each other give 0 or 360 by rounding.
std::vector<ThinWedge> thin_region_wedges(const core::SurfaceNetwork& surface, double below_deg);

/// A spike tip: a vertex T with exactly three faces (T, a, b), (T, b, c), (T, c, a) of one
/// region R, whose cone there is convex and thin (a wedge of R at one of its edges T-x under
/// `fan_wedge_below_deg`). A tet of R on T-x has a dihedral angle at T-x no larger than the
/// share of the wedge it covers, so with a wedge under twice an angle m the only tet that
/// reaches m there is (T, a, b, c): four surface nodes and three surface faces, which no
/// volume operation can change. Its smallest dihedral angle lies at T-a or T-b (the wedges)
/// or, in the flat sliver of a thin fin (T-c across a-b), at c-a and c-b: about the wedge at
/// T-a times (|ca| / |Ta|) dist(T, ab) / dist(c, ab), and likewise for b: a vertex c far
/// from the line ab closes them.
struct ForcedTet {
    Eigen::Vector3d tip;            ///< T
    core::Label region = 0;         ///< R
    double min_dihedral_deg = 0.0;  ///< of (T, a, b, c)
};

/// Spike tips of `surface` whose fan has a region wedge under `fan_wedge_below_deg` (in
/// vertex order, then region). Cost O(m) for m faces.
std::vector<ForcedTet> forced_tets(const core::SurfaceNetwork& surface, double fan_wedge_below_deg);

/// Splits the longest edge of faces with an angle over `max_angle_deg` (most obtuse first, a
/// face once per pass, three passes): a triangle with an angle over about 130 degrees leaves
/// every tetrahedron built on it a skewness over 0.8, whatever its fourth point. The new
/// vertex lies on the edge's curve (arc length, between the ends) or on the patch of its two
/// faces (projected), at the foot of an opposite vertex or the middle, a quarter of the edge
/// from its ends at least; every face at the edge is halved. A split is kept only when no new
/// face turns by 30 degrees or more from the face it halves, the largest angle at the edge
/// drops by 5 degrees or more and the smallest stays at least min(its old value,
/// `guard_deg`). `constraints` grow with the surface (curves, face patches, vertex face
/// hints). Returns the splits; cost O(faces) per pass.
std::size_t split_obtuse_faces(core::SurfaceNetwork& surface,
                               const std::vector<const BackgroundPatch*>& patches,
                               SurfaceConstraints& constraints, double max_angle_deg,
                               double guard_deg);

/// Improves `surface` in place: per pass, each vertex in id order moves to the angle-based
/// position (the mean of its ring neighbours' edges rotated onto the bisectors of their ring
/// angles), projected back onto its patch (`patches[face_patch]`, local descent from its
/// background face hint); curve vertices move to the arc-length midpoint of their curve
/// neighbours; a move is kept only if the smallest angle of the faces around the vertex does
/// not drop and no face turns by more than `max_normal_turn_deg`. Then edges inside a patch
/// are flipped where both faces are flat within `flip_max_dihedral_deg` and the smaller
/// minimum angle of the pair grows. Region wedges (ThinWedge, folded as thin_region_wedges
/// counts them) at junction edges: no move or flip may lower one under min(wedge_target_deg, 20)
/// (or lower one already under it), and a last pass raises those under wedge_target_deg by moves
/// along patches and curves and flips. Then the tip pass: each ForcedTet (fan wedge under 2
/// tip_target_deg) whose tet has a dihedral angle under tip_target_deg gets moves of its free and
/// curve vertices that raise it (no other forced tet of the moved vertex may drop, no face under
/// min(its angle, 22), a region wedge may drop only to the raised tet angle: the fan's wedges are
/// angles of its tet). Topology of curves and patches is kept; deterministic.
/// `constraints.vertex_face` is updated. Preconditions: sizes match the surface.
SmoothingReport smooth_surface(core::SurfaceNetwork& surface,
                               const std::vector<const BackgroundPatch*>& patches,
                               SurfaceConstraints& constraints, const SmoothingParams& params,
                               core::StageContext& ctx);

}  // namespace frontmesh::surface
