#pragma once
// The precondition of the tetra stage on a surface a user hands in (input.surface with
// --from tetra): what the layered front (paper §3.1.2) needs, checked before any work.

#include <cstdint>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "pipeline/core/surface_network.h"

namespace frontmesh::core {

/// Throws InputError with one line "SOURCE: <defect> near (x, y, z) mm" for the first face
/// (in id order) that no stage can work with, whatever stage a user's surface enters at:
/// a vertex id out of range, a non-finite coordinate, no face at all, a region_in that is
/// not a positive label, or a region_out that is negative or equals region_in (a face must
/// separate two regions; the message counts the faces with the same defect). Cost O(faces).
void require_valid_regions(const SurfaceNetwork& surface, const std::string& source);

/// An edge where a region's boundary is open (an odd number of the region's faces) or
/// misoriented (its faces, seen from the region, do not alternate in direction).
struct BoundaryDefect {
    Label region = 0;
    std::int32_t lo = -1, hi = -1;                    ///< the edge's vertices, lo < hi
    std::size_t faces = 0;                            ///< the region's faces on the edge
    bool is_open = false;                             ///< false: misoriented
    Eigen::Vector3d place = Eigen::Vector3d::Zero();  ///< the edge's midpoint, mm

    /// "open boundary of region R at edge (a, b) with N face(s) near (x, y, z) mm".
    std::string text() const;
};

/// The first boundary defect in (region, lo, hi) order, or none when every region's
/// boundary is closed and consistently oriented edge by edge (its enclosed volume is not
/// looked at). Faces of an interface count for both regions (reversed for region_out).
/// Precondition: vertex ids in range. Cost O(F log F).
std::optional<BoundaryDefect> first_boundary_defect(const SurfaceNetwork& surface);

/// The first place (edges in vertex order, then vertices in id order) where the domain's outer
/// boundary, the faces against label 0, is not a 2-manifold: an edge with more than two of
/// its faces, or a vertex whose faces there form more than one fan (linked through edges with
/// two). The referee (meshcheck.py) calls a mesh with such a boundary invalid, whatever its
/// tets. One line naming the place, or none. Precondition: vertex ids in range. O(F log F).
std::optional<std::string> outer_boundary_defect(const SurfaceNetwork& surface);

/// Throws InputError with one line "SOURCE: <defect>, region R, near (x, y, z) mm" for the
/// first defect found, in this order: a vertex id out of range or a non-finite coordinate;
/// a face whose region_in is not positive or equals its region_out; a face repeating a
/// vertex or of zero area (exact predicate); a region boundary that is open (an edge with an
/// odd number of the region's faces) or misoriented (its faces do not alternate in
/// direction around an edge, or the region encloses a non-positive volume: faces must point
/// out of region_in); the outer boundary not a 2-manifold (outer_boundary_defect); a part of a
/// region's boundary turned inside out (core::inverted_parts); two faces that intersect
/// (core::self_intersections). Even numbers of faces around an edge are accepted (2^q, §3: regions
/// touching along an edge inside the domain). Cost: O(n log n), dominated by the self-intersection
/// search (about 2 s per million faces).
void require_meshable_surface(const SurfaceNetwork& surface, const std::string& source);

/// What tetra needs beyond a meshable surface, since it keeps every given triangle: throws
/// InputError naming the first face (in id order) on which every tet would be degenerate to
/// the referee (best tet volume A * L / 3 under 1e-10 of the regular tet of the surface's
/// mean edge: a nearly collinear or a tiny triangle). Cost O(faces).
void require_tetra_ready_faces(const SurfaceNetwork& surface, const std::string& source);

}  // namespace frontmesh::core
