#pragma once
// The tetrahedral mesh handed between tetra, refine and the exporters (STYLE §2).

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/ids.h"
#include "pipeline/core/surface_network.h"

namespace frontmesh::core {

/// Tetrahedra of one or more regions that share their interfaces (conforming).
///
/// Node order of a tet is VTK's: the triangle (p0, p1, p2) seen from p3 is counter-clockwise,
/// i.e. tet_signed_volume(p0, p1, p2, p3) > 0 (quality.h), which is orient3d(p0, p1, p2, p3) < 0
/// in predicates.h's sign convention.
///
/// Nodes 0 .. surface_vertices-1 are the vertices of the input surface, in its order and at its
/// exact coordinates; `faces` are the input surface's triangles (boundary and interfaces, each
/// once) with the SurfaceNetwork conventions: normal out of region_in, region_out 0 = outside.
/// Memory: 24 B per node + 20 B per tet (+ 4 B per node for `level`).
struct TetMesh {
    std::vector<double> xyz;                        ///< 3 per node, mm
    std::vector<std::array<std::int32_t, 4>> tets;  ///< node ids, VTK order (positive volume)
    std::vector<Label> region;                      ///< per tet, > 0

    std::vector<std::array<std::int32_t, 3>> faces;  ///< boundary + interface triangles
    std::vector<Label> region_in;                    ///< per face
    std::vector<Label> region_out;                   ///< per face, 0 = outside
    std::int32_t surface_vertices = 0;               ///< nodes [0, surface_vertices) are on `faces`

    std::vector<std::int32_t> level;  ///< per node front level (0 = input surface);
                                      ///< empty when unknown

    /// After io::split_interfaces (interfaces split for tie or contact; the mesh is then not
    /// conforming there): per node, the node it is a copy of (itself for a node that is not a
    /// copy), and per face, the same triangle seen from the other side of a split interface
    /// (a split interface face is stored once per side, each oriented out of its region_in),
    /// -1 for the other faces. Both empty when no interface is split.
    std::vector<std::int32_t> twin;
    std::vector<std::int32_t> face_twin;

    /// Quadratic tets (output.order 2, volume::elevate_to_quadratic): per tet its six mid-edge
    /// nodes in VTK's edge order (core::kTetEdge: 01, 12, 20, 03, 13, 23), per face its three
    /// (core::kTriEdge: 01, 12, 20). The mid nodes are numbered after every corner node, one
    /// per edge (core/quadratic_nodes.h). Both empty for linear tets (every stage works on
    /// those; only the exports see quadratic ones). Memory: 24 B per tet + 12 B per face.
    std::vector<std::array<std::int32_t, 6>> tet_mid;
    std::vector<std::array<std::int32_t, 3>> face_mid;
    bool is_quadratic() const { return !tet_mid.empty(); }

    std::size_t node_count() const { return xyz.size() / 3; }
    std::size_t tet_count() const { return tets.size(); }
    std::size_t face_count() const { return faces.size(); }

    Eigen::Map<const Eigen::Vector3d> point(std::int32_t v) const {
        return Eigen::Map<const Eigen::Vector3d>(&xyz[3 * static_cast<std::size_t>(v)]);
    }
    Eigen::Map<Eigen::Vector3d> point(std::int32_t v) {
        return Eigen::Map<Eigen::Vector3d>(&xyz[3 * static_cast<std::size_t>(v)]);
    }
    std::int32_t add_node(const Eigen::Vector3d& p) {
        xyz.push_back(p.x());
        xyz.push_back(p.y());
        xyz.push_back(p.z());
        return static_cast<std::int32_t>(node_count() - 1);
    }
    void add_tet(std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t d, Label r) {
        tets.push_back({a, b, c, d});
        region.push_back(r);
    }
};

/// The boundary and interface triangles of a mesh as a SurfaceNetwork (nodes
/// [0, surface_vertices) only), e.g. to compare with the surface it was meshed from.
SurfaceNetwork boundary_surface(const TetMesh& mesh);

/// Fills mesh.faces / region_in / region_out from the tets: every face of exactly one tet
/// (region_out 0) and every face between tets of two regions (stored once, oriented out of
/// the smaller region label). Deterministic. surface_vertices is left as it is.
void derive_boundary_faces(TetMesh& mesh);

}  // namespace frontmesh::core
