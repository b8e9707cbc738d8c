#pragma once
// Checks of an image file's header and data size made before ITK reads the file. ITK and the
// format libraries under it call abort() on non-finite geometry (VNL), silently replace a
// zero or NaN NIfTI spacing by 1 mm, and allocate what a header announces before noticing
// that the data file is short; so the header is read and checked here first (issue 21).

#include <cstdint>
#include <string>
#include <vector>

namespace frontmesh::io {

/// Default of input.max_image_gib, the memory an image may take while it is read: 4 GiB.
inline constexpr double default_max_image_gib = 4.0;
/// Bytes per voxel of the label grid the reader builds (int32), held beside the file's voxels.
inline constexpr std::uint64_t label_bytes = 4;
/// Smallest voxel spacing (mm) taken from a file; below it the header is taken as damaged.
/// (At 1e-6 mm the pipeline already loses detail: a 16^3 sphere meshed with 40 nodes instead
/// of 123 and 14% of its volume missing; at 1e-5 mm it was intact. 1e-4 keeps a factor 10.)
inline constexpr double min_spacing_mm = 1e-4;
/// Largest voxel spacing (mm) taken from a file (10 m).
inline constexpr double max_spacing_mm = 1e4;
/// Largest magnitude of an origin coordinate (mm) taken from a file (1 km). Beyond it a
/// voxel's coordinates keep too few digits of its size (ITK itself refuses a NIfTI sform
/// offset of 1e9 mm with an unrelated message about direction cosines).
inline constexpr double max_origin_mm = 1e6;

/// What check_image_header checks besides the header's consistency.
struct HeaderLimits {
    /// Check the spacing values (false when input.spacing replaces them).
    bool check_spacing = true;
    /// input.max_image_gib: the largest estimated memory of reading the image, in GiB.
    double max_image_gib = default_max_image_gib;
};

/// "input.image: 'PATH' ", the start of every message about the image at `path`.
std::string image_prefix(const std::string& path);

/// Throws InputError unless `file` (the image at `path`, or a file it refers to, described
/// by `role` such as "data file") is a regular file. Uses stat only: a named pipe, device or
/// socket is refused without being opened, so reading never blocks on it.
void require_regular_file(const std::string& path, const std::string& file,
                          const std::string& role);

/// Throws InputError naming `field` and input.max_image_gib unless `extents` voxels (each
/// extent >= 1) of `voxel_bytes` bytes in the file, plus their int32 labels, take at most
/// `max_image_gib` GiB: the memory read_label_image holds while it converts. Never overflows.
void check_image_memory(const std::string& path, const std::string& field,
                        const std::vector<std::uint64_t>& extents, std::uint64_t voxel_bytes,
                        double max_image_gib);

/// Throws InputError naming `field` unless `spacing_mm` is finite and within
/// [min_spacing_mm, max_spacing_mm].
void check_spacing(const std::string& path, const std::string& field, double spacing_mm);

/// Throws InputError naming `field` unless `origin_mm` is finite and |origin_mm| is at most
/// max_origin_mm.
void check_origin(const std::string& path, const std::string& field, double origin_mm);

/// The message for `count` non-finite voxels of a float image, the first (in file order) at
/// (i, j, k) with value `value` ("nan", "inf", "-inf").
std::string non_finite_voxels_message(const std::string& path, const std::string& value,
                                      std::uint64_t i, std::uint64_t j, std::uint64_t k,
                                      std::uint64_t count);

/// Reads and checks the header of `file`, which is the image at `path` or (a series) its
/// first file, when it is NIfTI-1/NIfTI-2 (.nii, .nii.gz, .hdr/.img, .img.gz), MetaImage
/// (.mha, .mhd) or NRRD (.nrrd, .nhdr); other formats are left to ITK and the checks after
/// it. Checked: every dimension >= 1; the voxel type; the memory estimate (check_image_memory)
/// within `limits.max_image_gib`; the spacing (when `limits.check_spacing`) finite and
/// within [min_spacing_mm, max_spacing_mm]; orientation and origin (sform, qform, transform
/// matrix, space directions) finite and non-singular, origins within max_origin_mm; a data
/// file named by the header is a regular file; the data holds at least the bytes the header
/// announces: compared with the file size when raw, counted by decompressing once when
/// gzip/zlib (.nii.gz, .img.gz, MetaImage CompressedData, NRRD gzip; about 30 ms per 10 MB
/// of voxels), bounded below by two bytes per voxel when text (MetaImage BinaryData False,
/// NRRD ascii) or hex. NIfTI float32/float64 voxels are scanned for NaN and inf in the same
/// pass, since niftilib silently turns them into 0 before ITK returns them.
/// Throws InputError, one line naming the file and the header field (or voxel).
void check_image_header(const std::string& path, const std::string& file,
                        const HeaderLimits& limits);

}  // namespace frontmesh::io
