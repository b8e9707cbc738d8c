#pragma once
// Connected components of a label array: the voxel side of the component thresholds
// (issue 20: a threshold compares the voxel volume the user sees, not the volume an
// extracted surface happens to enclose).

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/ids.h"

namespace frontmesh::surface {

/// Voxels of one label joined through shared faces (6-connectivity). After extract's
/// manifold clean-up two pieces of a label never touch only along an edge or at a corner,
/// so these are then also the 26-connected components, and each is one piece of surface.
struct LabelComponent {
    core::Label label = 0;
    std::size_t voxels = 0;
    Eigen::Vector3d centre_index = Eigen::Vector3d::Zero();  ///< mean index of its voxels
    /// The one label that every voxel sharing a face with the component carries (a voxel
    /// beyond the image border counts as label 0), or -1 when they carry several.
    core::Label surrounding = -1;
    bool touches_border = false;  ///< some voxel lies on the image border
};

/// Every component of a label array, label 0 included.
struct LabelComponents {
    std::vector<LabelComponent> list;    ///< in order of their first voxel (x fastest)
    std::vector<std::int32_t> of_voxel;  ///< per voxel: its component's index in `list`
};

/// The 6-connected components of `labels` (dims[0] x dims[1] x dims[2] voxels, x fastest).
/// Cost: three linear passes (union-find with path halving); memory 4 B per voxel plus
/// about 50 B per component. Throws InputError for an image of 2^31 voxels or more.
LabelComponents label_components(const std::array<int, 3>& dims,
                                 const std::vector<core::Label>& labels);

/// The labelled components of `labels` that hold one of `seeds` (each once, in the order of
/// the first seed in it; seeds on label 0 are skipped). `visit(c, v)` is called once for
/// each voxel v of component c. Cost: the voxels of those components; memory 1 B per voxel
/// plus the queue.
std::vector<LabelComponent> components_containing(
    const std::array<int, 3>& dims, const std::vector<core::Label>& labels,
    const std::vector<std::size_t>& seeds,
    const std::function<void(std::size_t component, std::size_t voxel)>& visit);

}  // namespace frontmesh::surface
