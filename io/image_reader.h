#pragma once
// Reading segmented or grayscale 3-D images with ITK into a LabelImage in physical mm.

#include <optional>
#include <string>

#include <Eigen/Core>

#include "io/image_header.h"
#include "pipeline/core/label_image.h"

namespace frontmesh::io {

struct ImageReadOptions {
    /// Grayscale input: voxels with value > threshold become label 1, the rest 0.
    std::optional<double> threshold;
    /// Voxel spacing (mm) for TIFF/PNG slice stacks, which carry none; overrides the file's
    /// spacing for other formats when set.
    std::optional<Eigen::Vector3d> spacing;
    /// Output frame: ITK's LPS, or the NIfTI/neuroimaging RAS world (x and y negated).
    core::Frame frame = core::Frame::Lps;
    /// Voxels of label 0 added on every side so that objects touching the border close.
    int pad = 1;
    /// input.max_image_gib: the largest memory (GiB) reading may take, estimated from the
    /// header as voxels x (bytes per voxel in the file + 4 bytes of label); > 0.
    double max_image_gib = default_max_image_gib;
};

/// Reads `path`: a file (.nii, .nii.gz, .mha, .mhd, .nrrd, .nhdr, or a single 3-D .tif),
/// a folder holding a DICOM series or a TIFF/PNG slice stack (slices in name order), or a
/// printf pattern such as "slices/img_%03d.png" (numbers from the lowest one found upward).
/// Integer voxel types become labels as they are; float voxels must be finite, and integral
/// unless `threshold` is set. Spacing, origin and direction are honoured.
/// Before ITK reads anything, `path` must be a regular file or a folder (a named pipe or a
/// device is refused unopened) and its header passes check_image_header (io/image_header.h):
/// its memory estimate within `max_image_gib`, spacing within [min_spacing_mm,
/// max_spacing_mm], origin within max_origin_mm, finite non-singular orientation, data at
/// least as long as the header announces (and a NIfTI float image without NaN or inf).
/// Throws InputError, one line naming the path (and the header field, data file or voxel),
/// when it is missing, unreadable, malformed, not 3-D, has a non-finite voxel (the message
/// names the first and counts them all; a threshold does not help, NaN is not below or
/// above it), non-integral
/// labels without a threshold, labels outside int32, or is a slice stack without spacing.
core::LabelImage read_label_image(const std::string& path, const ImageReadOptions& options);

/// Every check of read_label_image that needs no voxel data (the path, the header as read
/// here and by ITK, the data size), for `frontmesh validate`. Reads headers only (and
/// decompresses a .nii.gz once to count its bytes). Throws InputError as read_label_image.
void check_label_image(const std::string& path, const ImageReadOptions& options);

}  // namespace frontmesh::io
