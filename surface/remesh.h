#pragma once
// Remesh stage, the paper's §2 surface mesh generation (issue 3): the direct advancing-front
// triangulation on the background mesh, features kept, sizes graded, then angle-based
// smoothing.
//   In:  the repaired SurfaceNetwork as background (closed, oriented), RemeshParams.
//   Out: a new SurfaceNetwork, isotropic and graded, every vertex on the background (within
//        h / 10 with remesh.preserve_volume, which moves faces to keep region volumes),
//        interfaces shared, junction curves kept; the target size per vertex.
//   Next: tetra (its initial front).
// Implementation: surface/remesh.cpp (the driver) and remesh_*.cpp; the file map is in
// surface/remesh_internal.h.

#include <array>
#include <cstddef>
#include <map>
#include <vector>

#include "pipeline/core/stage_context.h"
#include "pipeline/core/stage_params.h"
#include "pipeline/core/surface_network.h"

namespace frontmesh::surface {

/// Parameters of the remesh stage: member `m` is recipe key `remesh.m`; default, range and
/// unit are declared in remesh_keys().
struct RemeshParams {
    /// h, mm, >= 0; 0 = derived from the input: twice the mean background edge length (about
    /// 1.3 voxels on a marching-cubes surface).
    double edge_length = 0.0;
    double gradation = 1.3;            ///< >= 1: max growth of h per mm is (g - 1)
    double min_edge_length = 0.0;      ///< mm, >= 0; 0 = h / 4
    double max_edge_length = 0.0;      ///< mm, >= 0; 0 = 4 h
    double curvature_angle_deg = 0.0;  ///< [0, 90): max turning angle per edge; 0 = off
    int thickness_layers = 0;          ///< >= 0: thin regions get N edges across; 0 = off
    /// [0, 180): edges whose faces turn by more are sharp features; 0 = off (marching-cubes
    /// staircases would otherwise become features).
    double feature_angle_deg = 0.0;
    std::map<core::Label, double> label_edge_length;  ///< mm per region label, > 0
    int smoothing_iterations = 5;                     ///< >= 0: angle-based smoothing + flip passes
    double flip_max_dihedral_deg = 10.0;              ///< [0, 90]: flip only edges this flat
    bool check_self_intersections = true;             ///< exact check of the result (GeometryError)
    /// >= 0, percent: a region whose enclosed volume changes by more than this is meshed
    /// again with sizes scaled by about sqrt(limit / change) on its patches (chords of an
    /// inscribed mesh lose volume as h^2), for up to the stage's rounds; 0 = off.
    double max_volume_change_percent = 0.0;
    /// After the last round, each region's faces move along their normals (at most a tenth
    /// of h) so the region encloses the background's volume again (correct_region_volumes,
    /// surface/volume_correction.h): chords of an inscribed mesh lose volume as h^2, a thin
    /// or small region several per cent. Off: vertices stay on the background exactly.
    bool preserve_volume = true;
    /// tetra.max_edge_length, mm (set by the recipe, not a key of its own; 0 = none): the
    /// automatic h (edge_length 0) is at most this, so that the surface's triangles are no
    /// larger than the tets the cap asks for inside (a front over triangles wider than the
    /// cap lays flat tets: a ball with 1.97 mm triangles under a 1.2 mm cap had 26% of its
    /// tets over skewness 0.8 after tetra, 1% after refine).
    double volume_edge_cap = 0.0;
};

/// Every `remesh.*` recipe key: the member it sets, default, range, unit and a one-line
/// doc (surface/remesh_params.cpp). The one declaration that validate(), the recipe reader
/// and `frontmesh keys` read; the member defaults above equal its defaults (a test checks).
const core::ParamTable<RemeshParams>& remesh_keys();

/// Throws InputError "remesh.KEY: must be in RANGE, got VALUE" for a member outside its
/// declared range (and for the checks between keys).
void validate(const RemeshParams& params);

struct RemeshResult {
    core::SurfaceNetwork surface;     ///< closed, oriented, regions as in the background
    std::vector<double> target_size;  ///< per output vertex, mm
};

/// h used for edge_length 0: twice the mean edge length of the background (mm).
double default_edge_length(const core::SurfaceNetwork& background);

/// h the stage uses: remesh.edge_length, or for 0 default_edge_length, at most
/// params.volume_edge_cap.
double resolved_edge_length(const RemeshParams& params, const core::SurfaceNetwork& background);

/// Features -> size field -> curves discretised by the size field -> every patch triangulated
/// by the advancing front (TBB-parallel over patches, deterministic) -> one network with the
/// curve points shared exactly -> angle-based smoothing with projection and edge flips ->
/// checks. Counters `remesh.*` go to ctx.
/// When the last round still fails (a front stalls, or the result is open, misoriented, turned
/// inside out or self-intersecting), the background is the result, with a warning naming the
/// failure and `remesh.fallback_to_background` = 1, if it has no such defect itself.
/// Throws InputError (bad params, empty background), else MeshingError or GeometryError (that
/// failure, naming region or place) when the background cannot stand in either.
RemeshResult remesh(const core::SurfaceNetwork& background, const RemeshParams& params,
                    core::StageContext& ctx);

/// Sampled two-sided distance between two surfaces (mm): vertices, edge midpoints and face
/// centroids of each projected onto the other (closest point through an ADT).
struct HausdorffDistance {
    double a_to_b = 0.0;  ///< max over samples of a of the distance to b
    double b_to_a = 0.0;
    double mean_a_to_b = 0.0;
    double mean_b_to_a = 0.0;
    double max() const { return a_to_b > b_to_a ? a_to_b : b_to_a; }
};
HausdorffDistance hausdorff_distance(const core::SurfaceNetwork& a, const core::SurfaceNetwork& b);

/// Triangle quality of a surface (paper Eq. 2 eta and angles).
struct SurfaceQuality {
    std::size_t faces = 0;
    double min_angle_deg = 180.0;
    double mean_eta = 0.0;
    double max_eta = 0.0;
    double fraction_below_20_deg = 0.0;           ///< faces with min angle < 20 degrees
    double fraction_at_least_30_deg = 0.0;        ///< faces with min angle >= 30 degrees
    std::array<std::size_t, 10> eta_histogram{};  ///< bins of width 0.1 over [0, 1]
};
SurfaceQuality surface_quality(const core::SurfaceNetwork& surface);

/// Fraction of the surface's edges whose length lies in [lo, hi] mm.
double edge_length_fraction(const core::SurfaceNetwork& surface, double lo, double hi);

}  // namespace frontmesh::surface
