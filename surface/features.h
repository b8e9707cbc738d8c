#pragma once
// Features of the background surface for the remesher (paper §2: "geometrical features are
// extracted from the background mesh"): junction curves where regions meet, sharp edges by a
// dihedral threshold, corners, and the patches the curves separate. Implementation:
// surface/features.cpp, one named function per step of find_features.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/stage_context.h"
#include "pipeline/core/surface_network.h"

namespace frontmesh::surface {

/// Undirected edges of a triangle network with their incident faces (any number: the network
/// is non-manifold at junctions). Edge ids follow the sorted (min vertex, max vertex) order.
/// Memory: about 40 B per face.
struct EdgeTable {
    std::vector<std::array<std::int32_t, 2>> vertices;  ///< per edge (v0 < v1)
    std::vector<std::int32_t> face_offsets;             ///< CSR into edge_faces, size edges + 1
    std::vector<std::int32_t> edge_faces;               ///< incident faces, increasing per edge
    std::vector<std::int32_t> face_edges;               ///< 3 per face: edge of (f[i], f[i+1])

    std::size_t edge_count() const { return vertices.size(); }
    std::int32_t face_count(std::int32_t e) const {
        return face_offsets[std::size_t(e) + 1] - face_offsets[std::size_t(e)];
    }
    /// The edge between faces' local vertices i and i + 1 of face f.
    std::int32_t edge_of(std::int32_t f, int i) const { return face_edges[3 * std::size_t(f) + i]; }
};

/// Builds the edge table. Cost O(m log m) for m faces.
EdgeTable edge_table(const core::SurfaceNetwork& surface);

/// A feature curve: a polyline of background vertices from corner to corner. Consecutive
/// vertices are background edges. A closed curve without corner repeats its first vertex at
/// the end (`is_closed`); a curve from a corner back to the same corner also ends where it
/// starts but is not `is_closed` (its end point is a corner).
struct FeatureCurve {
    std::vector<std::int32_t> vertices;
    bool is_closed = false;
};

/// One use of a curve by a patch boundary loop.
struct CurveUse {
    std::int32_t curve = -1;
    bool forward = true;  ///< the patch lies to the left of the curve in this direction
};

/// A connected set of background faces with the same (region_in, region_out) pair, bounded by
/// feature curves. Its faces keep the background's orientation.
struct Patch {
    core::Label region_in = 0;
    core::Label region_out = 0;
    std::vector<std::int32_t> faces;  ///< background face ids, increasing
    /// Boundary loops, each a closed chain of curve uses (end of one = start of the next)
    /// with the patch to the left. Empty for a patch without boundary (a closed surface).
    std::vector<std::vector<CurveUse>> loops;
};

struct Features {
    std::vector<FeatureCurve> curves;
    std::vector<std::int32_t> corners;          ///< background vertex ids, increasing
    std::vector<Patch> patches;                 ///< ordered by their smallest face id
    std::vector<std::int32_t> face_patch;       ///< per background face
    std::vector<std::uint8_t> is_feature_edge;  ///< per EdgeTable edge
    EdgeTable edges;
    std::size_t junction_edges = 0;  ///< edges where the region pairs change or > 2 faces meet
    std::size_t sharp_edges = 0;     ///< further edges sharper than the feature angle
};

/// Finds junction curves (edges where the incident faces' (region_in, region_out) pairs differ
/// or more than two faces meet), sharp edges (dihedral angle between face normals above
/// `feature_angle_deg`; 0 = none), corners (curve vertices of feature valence != 2, and, with
/// a feature angle, curve vertices where the curve turns by more than it), the curves between
/// corners, the patches they separate and each patch's boundary loops. Sharp edges that do not
/// separate two patches (dangling in a patch) are dropped. Deterministic.
/// `face_part` (empty, or one entry per face) cuts patches further: an edge between faces of
/// different parts is a junction edge (the remesher's cuts around a place where the front
/// stalls, surface/remesh_cuts.cpp).
/// Throws GeometryError (naming the vertex) when a patch boundary cannot be followed.
/// Cost O(m log m) for m faces.
Features find_features(const core::SurfaceNetwork& background, double feature_angle_deg,
                       core::StageContext& ctx, const std::vector<std::int32_t>& face_part = {});

}  // namespace frontmesh::surface
