#pragma once
// Quadratic tets (recipe key output.order: 2): mid-edge nodes for the exports, curved onto
// the background surface on boundaries and interfaces, never inverting an element.

#include <array>
#include <cstddef>

#include <Eigen/Core>

#include "pipeline/core/surface_network.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::volume {

/// What elevate_to_quadratic did (for the log and summary).
struct QuadraticStats {
    std::size_t edges = 0;           ///< mid nodes added (one per edge)
    std::size_t surface_edges = 0;   ///< edges on a boundary or interface
    std::size_t curved = 0;          ///< of those, mid node on the background in the result
    std::size_t straightened = 0;    ///< curved placements taken back (element validity)
    std::size_t not_projected = 0;   ///< kept straight: junction curve, no background face
                                     ///< of the edge's two regions, or too far from the chord
    double min_scaled_jacobian = 1;  ///< smallest bound of det J / det J_straight over tets
};

/// Smallest scaled Jacobian a quadratic tet may have: the lower bound of its Jacobian
/// determinant (min_bezier_jacobian) over that of the straight tet. Curving an edge that
/// would bring a tet below it is taken back.
inline constexpr double kMinScaledJacobian = 0.2;

/// A lower bound of the Jacobian determinant det J(xi) of the quadratic tet with corners
/// x[0..3] and mid nodes x[4..9] (VTK order, core::kTetEdge) over the whole element: the
/// smallest of the 20 Bernstein (Bezier) coefficients of det J, a cubic polynomial. Since the
/// cubic Bernstein polynomials are non-negative and sum to one, det J >= that coefficient
/// everywhere (and equals it at the corners, whose coefficients are det J there). For a
/// straight tet (mid nodes at the midpoints) every coefficient is det(x1-x0, x2-x0, x3-x0) =
/// 6 x its volume. Units mm^3. Cost: 64 3x3 determinants.
double min_bezier_jacobian(const std::array<Eigen::Vector3d, 10>& x);

/// A copy of `mesh` with quadratic tets (mesh.tet_mid, mesh.face_mid; mid nodes appended
/// after the corner nodes, one per edge: core::quadratic_nodes).
///
/// Placement: the mid node of an interior edge is its midpoint. The mid node of an edge on
/// the boundary or on one interface (every face of mesh.faces on it separates the same two
/// labels) is the closest point of `background` (the surface remesh projected onto) among
/// the background faces between those two labels, when that point lies within 0.2 edge
/// lengths of the midpoint; otherwise (curves where three or more regions meet, no such
/// background face, `background` null) the midpoint. Then every tet whose scaled Jacobian
/// bound (min_bezier_jacobian over the straight value) is below kMinScaledJacobian has its
/// curved edge of largest displacement taken back to the midpoint, until none is: each step
/// straightens one edge for good, so there are at most as many steps as curved edges, and a
/// tet with only straight edges has scaled bound 1. So every tet of the result has a
/// positive Jacobian everywhere, given positive input tets.
///
/// A mesh split by io::split_interfaces: the copies of an edge (the same two original nodes,
/// mesh.twin) are placed alike and taken back together, so the two sides of a split
/// interface keep the same curved shape; mid nodes get `twin` entries too.
/// Throws InternalError for a mesh that is already quadratic. Cost: O(tets + background
/// faces log faces).
core::TetMesh elevate_to_quadratic(const core::TetMesh& mesh,
                                   const core::SurfaceNetwork* background,
                                   QuadraticStats* stats = nullptr);

}  // namespace frontmesh::volume
