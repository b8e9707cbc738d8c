#pragma once
// Tetra stage, the paper's §3.1-3.2 (issue 4): the layered tetrahedral advancing front,
// one region at a time from its closed boundary, with local remeshing where the front fails.
//   In:  the remeshed SurfaceNetwork (closed, oriented; the initial front), TetraParams.
//   Out: a TetMesh filling every region; the input surface kept exactly as its first nodes
//        and its faces.
//   Next: refine.

#include "pipeline/core/stage_context.h"
#include "pipeline/core/stage_params.h"
#include "pipeline/core/surface_network.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::volume {

/// Parameters of the tetra stage: member `m` is recipe key `tetra.m`; default, range and unit
/// are declared in tetra_keys().
struct TetraParams {
    /// alpha of Eq. 4, the stretching factor of the element size from one front level to the
    /// next (h_o = 1.24 alpha sqrt(a)). Default 1.15, dimensionless, range (1.0, 2.0].
    double stretching = 1.15;
    /// Laplacian smoothing passes over the corrected heights h'_o of Eq. 6 on each level front
    /// (§3.1.3). Default 3, range [0, 100].
    int height_smoothing_iterations = 3;
    /// Local remeshings (§3.2) allowed per front node before a failing base is left for the
    /// next level / the closing phase. Default 3, range [0, 50].
    int max_remesh_per_node = 3;
    /// Angle of the paper's face-face (dihedral) and edge-face angle tests of step 4, degrees.
    /// Default 5, range [0, 30].
    double min_angle_deg = 5.0;
    /// Rounds of the closing phase for the cavities the layered front leaves (each round
    /// removes one more ring of tets around what is left and refills it with relaxed quality
    /// tests, exact validity tests kept). Default 8, range [0, 100].
    int max_closing_rounds = 8;
    /// Largest edge inside the volume, mm (0: no cap). The height of a new point over its
    /// base (Eqs. 6 and 8) is capped so that the new edges are not longer; edges the front
    /// still makes longer (joining existing nodes) are split by refine. Surface edges are
    /// the input's and are never changed. Default 0, range [0, 1e6].
    double max_edge_length = 0.0;
};

/// Every `tetra.*` recipe key: the member it sets, default, range, unit and a one-line
/// doc (volume/tetra_params.cpp). The one declaration that validate(), the recipe reader
/// and `frontmesh keys` read; the member defaults above equal its defaults (a test checks).
const core::ParamTable<TetraParams>& tetra_keys();

/// Throws InputError "tetra.KEY: must be in RANGE, got VALUE" for a member outside its
/// declared range.
void validate(const TetraParams& params);

/// Meshes every region of `surface` (closed, oriented SurfaceNetwork; faces' normals point out
/// of region_in) with the layered advancing front of §3.1-3.2.
///
/// Result: a TetMesh whose nodes [0, surface.vertex_count()) are the surface vertices (same
/// order, exact coordinates), faces/region_in/region_out = the surface's triangles, tets in VTK
/// order (positive volume, decided by exact predicates), `region` per tet, `level` per node (0
/// for surface nodes, n + 1 for nodes created on the n-th level front). Regions run in
/// parallel (TBB); new nodes are appended region by region in label order, so the result is
/// identical for any thread count and interfaces are identical by construction.
///
/// Every new tet passes exact tests against the current front (no front node in it, no
/// improper edge-face intersection), so the output is a conforming tetrahedralisation of each
/// region's boundary whenever the function returns.
///
/// Throws InputError on invalid params or an empty surface, MeshingError naming the region,
/// a place (mm) and the front size left when a region cannot be finished. All loops are
/// bounded. Cost: about O(tets log tets) for well-graded surfaces.
core::TetMesh tetra(const core::SurfaceNetwork& surface, const TetraParams& params,
                    core::StageContext& ctx);

}  // namespace frontmesh::volume
