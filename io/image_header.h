#pragma once
// Checks of an image file's header and data size made before ITK reads the file. ITK and the
// format libraries under it call abort() on non-finite geometry (VNL), silently replace a
// zero or NaN NIfTI spacing by 1 mm, and allocate what a header announces before noticing
// that the data file is short; so the header is read and checked here first (issue 21).

#include <cstdint>
#include <string>
#include <vector>

namespace frontmesh::io {

/// Largest image read, counted in the file's voxels before padding: 2^30 (1,073,741,824)
/// voxels, 4 GiB as int32 labels.
inline constexpr std::uint64_t max_image_voxels = std::uint64_t{1} << 30;
/// Smallest voxel spacing (mm) taken from a file; below it the header is taken as damaged.
inline constexpr double min_spacing_mm = 1e-4;
/// Largest voxel spacing (mm) taken from a file (10 m).
inline constexpr double max_spacing_mm = 1e4;

/// "input.image: 'PATH' ", the start of every message about the image at `path`.
std::string image_prefix(const std::string& path);

/// Throws InputError unless `file` (the image at `path`, or a file it refers to, described
/// by `role` such as "data file") is a regular file. Uses stat only: a named pipe, device or
/// socket is refused without being opened, so reading never blocks on it.
void require_regular_file(const std::string& path, const std::string& file,
                          const std::string& role);

/// Throws InputError naming `field` unless the product of `extents` (each >= 1) is at most
/// max_image_voxels. Never overflows.
void check_voxel_count(const std::string& path, const std::string& field,
                       const std::vector<std::uint64_t>& extents);

/// Throws InputError naming `field` unless `spacing_mm` is finite and within
/// [min_spacing_mm, max_spacing_mm].
void check_spacing(const std::string& path, const std::string& field, double spacing_mm);

/// Reads and checks the header of `file`, which is the image at `path` or (a series) its
/// first file, when it is NIfTI-1/NIfTI-2 (.nii, .nii.gz, .hdr/.img, .img.gz), MetaImage
/// (.mha, .mhd) or NRRD (.nrrd, .nhdr); other formats are left to ITK and the checks after
/// it. Checked: every dimension >= 1 and at most max_image_voxels in all; the voxel type; the
/// spacing (when `check_spacing_values`, i.e. input.spacing does not replace it) finite and
/// within [min_spacing_mm, max_spacing_mm]; orientation and origin (sform, qform, transform
/// matrix, space directions) finite and non-singular; a data file named by the header is a
/// regular file; uncompressed data holds at least the bytes the header announces (a .nii.gz
/// is decompressed once to count them, about 30 ms per 10 MB of voxels).
/// Throws InputError, one line naming the file and the header field.
void check_image_header(const std::string& path, const std::string& file,
                        bool check_spacing_values);

}  // namespace frontmesh::io
