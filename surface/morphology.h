#pragma once
// Voxel clean-up before contouring: morphological closing and opening of the labelled object
// (extract applies them for `ExtractParams::closing_voxels` and `opening_voxels`).

#include <cstddef>

#include "pipeline/core/label_image.h"

namespace frontmesh::surface {

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
