#pragma once
// Voxel clean-up before contouring: morphological opening of the labelled object.

#include <cstddef>

#include "pipeline/core/label_image.h"

namespace frontmesh::surface {

/// Voxel clean-up of the labelled object before contouring; recipe keys
/// `extract.closing_voxels` and `extract.opening_voxels`.
struct MorphologyParams {
    /// Radius (voxels) of the closing of the object: background gaps, slits and holes
    /// narrower than 2 r + 1 voxels are filled (one-voxel sulci whose sharp ends the remesher
    /// cannot follow). 0 = off. Range [0, 10].
    int closing_voxels = 0;
    /// Radius (voxels) of the opening of the object after the closing: sheets and spikes
    /// thinner than 2 r + 1 voxels are removed. 0 = off. Range [0, 10].
    int opening_voxels = 0;
};

/// Opens the union of all non-zero labels with the 6-neighbour diamond of radius `radius`
/// voxels (erosion then dilation, both by breadth-first distance, O(voxels)): sheets, spikes
/// and bridges of the object thinner than 2 radius + 1 voxels become background (label 0);
/// everything else, and every interface between labels, is unchanged. Removed voxels never
/// change to another label. Returns the number of voxels set to 0. radius <= 0: no change.
std::size_t open_object(core::LabelImage& image, int radius);

/// Closes the union of all non-zero labels with the same diamond (dilation then erosion):
/// gaps, slits and holes of the background narrower than 2 radius + 1 voxels are filled, each
/// filled voxel taking the label of the nearest object voxel (ties: the smallest label).
/// Object voxels never change. Returns the number of voxels filled.
std::size_t close_object(core::LabelImage& image, int radius);

}  // namespace frontmesh::surface
