#pragma once
// Numbering of the mid-edge nodes of quadratic tets (output.order 2): one node per edge of
// the mesh, shared by every tet and face on that edge, so that regions stay conforming.

#include <array>
#include <cstdint>
#include <vector>

#include "pipeline/core/tet_mesh.h"

namespace frontmesh::core {

/// The edges of a tet in VTK's order of the mid nodes of VTK_QUADRATIC_TETRA (nodes 4..9),
/// which is also Abaqus C3D10's and FEBio tet10's; Gmsh's tet10 swaps the last two.
inline constexpr int kTetEdge[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
/// The edges of a triangle in the order of the mid nodes of a 6-node triangle (VTK, Gmsh,
/// FEBio tri6): nodes 3, 4, 5.
inline constexpr int kTriEdge[3][2] = {{0, 1}, {1, 2}, {2, 0}};

/// Every edge of a tet mesh once, and the edges of each tet and face.
struct QuadraticNodes {
    /// Node pairs (smaller id first), in order of first use by the tets in id order (local
    /// order kTetEdge): deterministic, and the mid nodes of one tet lie close together.
    /// The mid node of edge e is node_count() + e of the mesh numbered.
    std::vector<std::array<std::int32_t, 2>> edges;
    std::vector<std::array<std::int32_t, 6>> tet_edges;   ///< per tet, in kTetEdge order
    std::vector<std::array<std::int32_t, 3>> face_edges;  ///< per mesh.faces entry, kTriEdge
};

/// The unique edges of `mesh` (its tets; every face edge is a tet edge). A mesh split by
/// io::split_interfaces has its own edges on each side (the nodes differ), so each side of a
/// split interface gets its own mid nodes. Throws InternalError when a face has an edge of
/// no tet. Cost: O(tets) expected (hash table of 16 B per edge while it runs).
QuadraticNodes quadratic_nodes(const TetMesh& mesh);

}  // namespace frontmesh::core
