#pragma once
// Editable topology of a tetrahedral mesh for the refine stage (§3.3): tet-tet adjacency through
// faces, node -> one incident tet, node stars and edge rings walked on demand, and a local
// "replace these tets by those" edit that keeps all of it valid. Flat arrays, int32 ids; dead
// tets go to a free list and nodes/tets are compacted only at the end (compact()).
//
// Walls: a face is a wall (neighbor -1) when it is on the hull, when it is one of mesh.faces
// (boundary or interface triangle) or when its two tets belong to different regions. No edit
// ever crosses a wall, so the input surface triangles and the regions are preserved exactly.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/tet_mesh.h"

namespace frontmesh::volume {

using Tet = std::array<std::int32_t, 4>;

/// Local index (0..3) of node v in tet t, -1 when absent.
inline int local_index(const Tet& t, std::int32_t v) {
    for (int i = 0; i < 4; ++i)
        if (t[static_cast<std::size_t>(i)] == v) return i;
    return -1;
}

/// Nodes of face i of a tet (the face opposite node i), ordered so that its right-hand normal
/// points out of the tet for a VTK-positive tet.
inline std::array<std::int32_t, 3> tet_face(const Tet& t, int i) {
    static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    return {t[static_cast<std::size_t>(kFace[i][0])], t[static_cast<std::size_t>(kFace[i][1])],
            t[static_cast<std::size_t>(kFace[i][2])]};
}

/// True when (a, b, c, d) has positive volume in the VTK sense (exact: orient3d < 0).
bool positive_tet(const double* a, const double* b, const double* c, const double* d);

class TetTopology {
public:
    /// Builds adjacency for `mesh` (taken by value; its tets and nodes are edited in place).
    /// Throws InputError when a face is shared by more than two tets.
    explicit TetTopology(core::TetMesh mesh);

    const core::TetMesh& mesh() const { return mesh_; }
    std::int32_t tet_capacity() const { return static_cast<std::int32_t>(mesh_.tets.size()); }
    std::int32_t node_capacity() const { return static_cast<std::int32_t>(node_tet_.size()); }
    std::size_t alive_tets() const { return alive_count_; }

    bool alive(std::int32_t t) const { return alive_[static_cast<std::size_t>(t)] != 0; }
    const Tet& tet(std::int32_t t) const { return mesh_.tets[static_cast<std::size_t>(t)]; }
    core::Label region(std::int32_t t) const { return mesh_.region[static_cast<std::size_t>(t)]; }
    /// Tet across face i (opposite node i) of t, -1 at a wall.
    std::int32_t neighbor(std::int32_t t, int i) const {
        return nbr_[static_cast<std::size_t>(t)][static_cast<std::size_t>(i)];
    }

    const double* xyz(std::int32_t v) const { return &mesh_.xyz[3 * static_cast<std::size_t>(v)]; }
    Eigen::Vector3d point(std::int32_t v) const { return mesh_.point(v); }
    void set_point(std::int32_t v, const Eigen::Vector3d& p);
    /// A new interior node at p (a Steiner node), unused until replace() puts it in tets;
    /// `level` is its front level when the mesh records levels.
    std::int32_t add_node(const Eigen::Vector3d& p, std::int32_t level);
    /// Edit counter: incremented by every set_point(), add_node() and replace(), so that a
    /// cache of per-tet measures can tell whether someone else edited the mesh.
    std::uint64_t stamp() const { return stamp_; }
    /// Nodes [0, surface_vertices) are fixed (input surface).
    bool is_surface_node(std::int32_t v) const { return v < mesh_.surface_vertices; }
    /// One alive tet containing v, -1 when v is removed or unused.
    std::int32_t node_tet(std::int32_t v) const { return node_tet_[static_cast<std::size_t>(v)]; }

    /// Tets containing v (walking through non-wall faces from node_tet(v)), in walk order.
    /// Not thread-safe (uses per-topology marks).
    /// Returns true when the star is closed (no wall face contains v): v is strictly interior
    /// to one region.
    bool star(std::int32_t v, std::vector<std::int32_t>& tets) const;
    /// As star(), but stops and returns false as soon as more than `limit` tets are found.
    bool star(std::int32_t v, std::vector<std::int32_t>& tets, std::size_t limit) const;

    /// The ring of tets around edge (a, b), starting at tet t (which must contain a and b):
    /// `tets[k]` contains a, b, ring[k], ring[k+1 mod n]. Oriented so that
    /// (a, b, ring[k], ring[k+1]) is a VTK-positive ordering of tets[k]'s nodes. Returns true when
    /// the ring is closed (the edge is interior to one region); false at a wall.
    bool edge_ring(std::int32_t a, std::int32_t b, std::int32_t t, std::vector<std::int32_t>& tets,
                   std::vector<std::int32_t>& ring) const;

    /// Replaces the alive tets `old_tets` (a connected cavity) by `new_tets` (same region),
    /// whose boundary must be exactly the cavity's boundary. Adjacency and node -> tet are
    /// updated; ids of old tets are reused. Nodes of old tets absent from the new ones become
    /// removed. Writes the ids of the new tets to `new_ids` when given.
    void replace(std::span<const std::int32_t> old_tets, std::span<const Tet> new_tets,
                 core::Label region, std::vector<std::int32_t>* new_ids = nullptr);

    /// True when (a, b, c) is an input triangle on which no tet can have skewness (Eq. 1) at or
    /// below kPoorFaceSkewness: the least skewness of a tet on a triangle is the triangle's own,
    /// 1 - A / A_opt (A_opt: the equilateral triangle in the same circumcircle), reached with
    /// the apex on the circumsphere of radius 3 r / (2 sqrt 2) above the circumcentre.
    bool is_poor_face(std::int32_t a, std::int32_t b, std::int32_t c) const;
    /// True when a face of t is a poor input triangle (is_poor_face).
    bool has_poor_face(const Tet& t) const;
    static constexpr double kPoorFaceSkewness = 0.8;

    /// Consistency of adjacency and node -> tet (for tests): every non-wall link symmetric and
    /// through a face with the same three nodes, node_tet pointing at an alive tet holding it.
    bool check() const;

    /// The edited mesh with dead tets and removed nodes dropped (nodes [0, surface_vertices)
    /// keep their ids; other nodes keep their relative order).
    core::TetMesh compact() const;

private:
    std::int32_t allocate();

    core::TetMesh mesh_;
    std::vector<std::array<std::int32_t, 4>> nbr_;
    std::vector<std::uint8_t> alive_;
    std::vector<std::int32_t> node_tet_;
    std::vector<std::int32_t> free_;
    std::uint64_t stamp_ = 0;
    std::vector<std::array<std::int32_t, 3>> poor_faces_;  ///< sorted node triples
    std::size_t alive_count_ = 0;
    mutable std::vector<std::uint32_t> mark_;  ///< star walk marks (not thread-safe)
    mutable std::uint32_t epoch_ = 0;
};

}  // namespace frontmesh::volume
