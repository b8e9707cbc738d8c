#pragma once
// Refine stage, the paper's §3.3: node removal, angle-based node smoothing and flips
// ("Delaunay refinement"), then a sliver pass beyond the paper.
//   In:  the TetMesh of tetra, RefineParams.
//   Out: an improved TetMesh; the input surface triangles, the surface nodes and the regions
//        are preserved exactly.
//   Last stage: the runner writes mesh.vtu and the exports from it.

#include "pipeline/core/stage_context.h"
#include "pipeline/core/stage_params.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::volume {

/// Parameters of refine(): member `m` is recipe key `refine.m`; default, range and unit are
/// declared in refine_keys().
struct RefineParams {
    /// §3.3.1: remove interior nodes with few tets around them (4: "inside a tetrahedron",
    /// 6: "inside a pyramid") and re-tetrahedralise the hole. bool.
    bool node_removal = true;
    /// Largest star (tets around a node) removed by node removal. Paper: 6. Range [4, 12].
    int node_removal_max_tets = 6;
    /// Rounds of smoothing + flips (§3.3: three times). Range [0, 20].
    int passes = 3;
    /// §3.3.2: angle-based smoothing of interior nodes in each round. bool.
    bool smoothing = true;
    /// Smoothing sweeps over all interior nodes per round. Range [1, 10].
    int smoothing_sweeps = 1;
    /// Nodes whose incident tets all have skewness (Eq. 1) at or below this are not smoothed
    /// (0: every interior node, as the paper). Range [0, 1).
    double smoothing_skewness = 0.0;
    /// §3.3.3: tets with skewness (Eq. 1) above this are flip candidates. Paper: 0.3. Range [0, 1).
    double flip_skewness = 0.3;
    /// Largest edge ring removed by edge suppression (n -> 2n-4 tets; 3 -> 2, 4 -> 4, ...).
    /// Range [3, 10].
    int flip_max_ring = 7;
    /// Require the paper's Delaunay condition (node A inside the circumsphere of the tet
    /// across face F, exact insphere) before trying flips across F. Off: every face of a
    /// candidate is tried and the quality criterion alone decides (about 1.6x slower, slightly
    /// better before the sliver pass). The sliver pass never uses it. bool.
    bool flip_delaunay_test = true;
    /// Sweeps over the flip candidates per round (stops early when nothing changes). Range [1, 20].
    int flip_sweeps = 4;
    /// Beyond the paper: a sliver pass (flips and node moves that raise the smallest dihedral
    /// angle) after the rounds. bool.
    bool sliver_pass = true;
    /// Tets whose smallest dihedral angle is below this are targeted by the sliver pass, degrees.
    /// Range (0, 70.5].
    double sliver_dihedral_deg = 25.0;
    /// Sweeps of the sliver pass. Range [1, 20].
    int sliver_sweeps = 5;
    /// Largest interior edge, mm (0: no cap). Not a refine.* key: the recipe sets it from
    /// tetra.max_edge_length, so that one key caps the element size of the volume. Interior
    /// edges longer than it are split at their midpoint after node removal; the smoothing,
    /// flips and sliver pass after that keep only changes whose edges stay within it, and the
    /// end checks again (edges on the input surface stay as they are, and an edge at a surface
    /// node may be as long as the longest surface edge there).
    double max_edge_length = 0.0;
};

/// Every `refine.*` recipe key: the member it sets, default, range, unit and a one-line
/// doc (volume/refine_params.cpp). The one declaration that validate(), the recipe reader
/// and `frontmesh keys` read; the member defaults above equal its defaults (a test checks).
const core::ParamTable<RefineParams>& refine_keys();

/// Throws InputError "refine.KEY: must be in RANGE, got VALUE" for a member outside its
/// declared range.
void validate(const RefineParams& params);

/// Improves `mesh` (returns an improved copy): boundary and interface triangles (mesh.faces)
/// and the surface nodes [0, mesh.surface_vertices) never change (positions and faces preserved
/// exactly), regions kept (a tet never crosses a region; flips only among tets of one region).
/// The sliver pass may add interior nodes (Steiner nodes), numbered after the others.
/// Records quality after each pass with ctx.count("refine.pass<k>.<figure>", v), k = 0 the
/// input, <figure> one of tets, max_skewness, mean_skewness, skew_over_08, min_dihedral; plus
/// per-step counts (refine.nodes_removed, refine.flips_3_2, refine.flips_2_3,
/// refine.flips_4_4, refine.flips_n_m, refine.smoothing_moves, refine.flip_attempts,
/// refine.edge_rings, refine.sliver.{flips,moves,removals,insertions}; refine.sliver.<figure> and
/// refine.final.<figure> after the sliver pass).
/// Deterministic (sequential edits in id order; the tets are first put in order of their
/// smallest node, so the input's tet order does not matter).
core::TetMesh refine(const core::TetMesh& mesh, const RefineParams& params,
                     core::StageContext& ctx);

}  // namespace frontmesh::volume
