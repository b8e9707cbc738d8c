#pragma once
// Extract stage, the first half of the paper's §2 background-mesh preparation ("a quality
// surface mesh is generated on an underlying discrete surface called a background mesh").
//   In:  a LabelImage (voxel labels, spacing, origin, direction), ExtractParams.
//   Out: a SurfaceNetwork in mm in the image's frame: one closed, outward-oriented
//        triangle boundary per chosen label, each interface once with both labels
//        (region_in / region_out). Before contouring, the optional voxel closing and
//        opening (surface/morphology.h) and the manifold clean-up edit the labels, and
//        components smaller than `min_component_volume_mm3` of voxels are left out. Every
//        connected component of a chosen label that is not meshed is named in a warning
//        and listed (StageContext::drop).
//   Next: repair.

#include <set>
#include <vector>

#include "pipeline/core/label_image.h"
#include "pipeline/core/stage_context.h"
#include "pipeline/core/stage_params.h"
#include "pipeline/core/surface_network.h"

namespace frontmesh::surface {

enum class ExtractMethod {
    Auto,         ///< flying_edges for one label, surface_nets for several
    FlyingEdges,  ///< VTK discrete flying edges (marching cubes); one label only
    SurfaceNets,  ///< multi-label surface nets: every cube decided once for all labels
};

/// Parameters of the extract stage: member `m` is recipe key `extract.m` (except `labels`,
/// from `input.labels`, and `min_component_volume_mm3`, from
/// `repair.min_component_volume_mm3`); default, range and unit are declared in
/// extract_keys() and repair_keys().
struct ExtractParams {
    std::vector<core::Label> labels;  ///< labels to mesh (`input.labels`); empty = all
    /// A connected component of a chosen label (6-connected voxels, see label_components.h)
    /// with fewer mm^3 of voxels than this, whose neighbouring voxels all carry one label, is
    /// given that label; so is a cavity (a component of the outside not on the image border)
    /// under this size inside one label. Measured on the voxels contoured: after the closing,
    /// opening, label blur and manifold clean-up; with flying_edges and a blur, on the voxels
    /// whose blurred mask exceeds 0.5. When no component of any chosen label reaches it,
    /// every component is kept (with a warning). `repair.min_component_volume_mm3`.
    double min_component_volume_mm3 = 1.0;
    ExtractMethod method = ExtractMethod::Auto;
    /// Gaussian blur (mm); 0 contours the voxels as they are. flying_edges: the label mask is
    /// blurred and contoured at 0.5. surface_nets: each label's indicator (0 included) is
    /// blurred and every voxel takes the label blurred largest there (ties: the smaller).
    double blur_sigma_mm = 0.0;
    /// surface_nets only: constrained smoothing passes (vertices stay in their cube, 0.1 voxel
    /// off its faces so that neighbouring vertices never coincide;
    /// junction curves smooth along themselves, corners stay).
    int smoothing_iterations = 8;
    double smoothing_relaxation = 0.5;  ///< surface_nets: step of each pass, (0, 1]
    /// surface_nets only: after smoothing, each region's boundary moves along its normals so
    /// the region encloses the volume of its voxels (correct_region_volumes,
    /// surface/volume_correction.h; at most a quarter voxel). Off: surface nets cut the voxels'
    /// corners (a 1,000-voxel blob loses about 7%).
    bool preserve_volume = true;
    /// Edit single voxels so that every region's boundary, and the outer boundary of the
    /// union of all chosen labels, is a 2-manifold (two pieces of a label, or two labels
    /// with the outside between them, touching only along a voxel edge or at a corner are
    /// joined there, else one voxel is given up). Counted.
    bool manifold_cleanup = true;
    /// Radius (voxels) of the closing of the labelled object before anything else: background
    /// gaps, slits and holes narrower than 2 r + 1 voxels are filled with the nearest label
    /// (one-voxel sulci whose sharp ends the remesher cannot follow). 0 = off. Counted
    /// (`extract.closing_filled_voxels`).
    int closing_voxels = 0;
    /// Radius (voxels) of the opening of the object after the closing: sheets and spikes
    /// thinner than 2 r + 1 voxels become background. 0 = off. Counted
    /// (`extract.opening_removed_voxels`).
    int opening_voxels = 0;
};

/// Every `extract.*` recipe key: the member it sets, default, range, unit and a one-line
/// doc (surface/extract_params.cpp). The one declaration that validate(), the recipe reader
/// and `frontmesh keys` read; the member defaults above equal its defaults (a test checks).
const core::ParamTable<ExtractParams>& extract_keys();

/// Throws InputError "extract.KEY: must be in RANGE, got VALUE" for a member outside its
/// declared range, "input.labels: ..." for a label <= 0, and
/// "repair.min_component_volume_mm3: ..." for a negative or non-finite minimum.
void validate(const ExtractParams& params);

/// The labels extract meshes (`labels`, or every label present when it is empty), checked
/// as extract checks them before any work: InputError when the image has no labelled voxel,
/// a chosen label is absent, or (every label chosen) a voxel holds a negative value. Also
/// used by `frontmesh validate`. Cost: one pass over the voxels.
std::set<core::Label> check_labels(const core::LabelImage& image,
                                   const std::vector<core::Label>& labels);

/// Contours the chosen labels. With several labels the result is one network: each
/// interface is one set of triangles carrying both labels (region_in = larger label,
/// region_out = smaller, 0 = outside), regions closed and oriented outward. A component of
/// a chosen label left out (too small, or lost to the closing, opening, blur or manifold
/// clean-up) is a warning "extract: label L: component of N voxels ... at (x, y, z) mm
/// not meshed: REASON" (the first 20 in full, then a count) and a ctx.drop() record each; a
/// chosen label left with no face at all is always a warning "extract: label L is not
/// meshed at all ...". Counters `extract.dropped_components`,
/// `extract.dropped_component_voxels`, `extract.filled_cavities`.
/// Throws InputError ("input.labels: ...") when a chosen label is absent from the image,
/// or the image has no labelled voxel; InputError "input.image 'FILE': nothing left to
/// mesh: ..." (naming the first component left out, its place and why) when no face is left.
core::SurfaceNetwork extract(const core::LabelImage& image, const ExtractParams& params,
                             core::StageContext& ctx);

}  // namespace frontmesh::surface
