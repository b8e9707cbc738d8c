#pragma once
// The coordinates frontmesh accepts from a file (issue 21, item 7): a surface or mesh far
// from the origin or scaled to nothing is bad input, named before any stage works on it.

#include <string>
#include <vector>

namespace frontmesh::core {

/// Largest |x|, |y| or |z| of a point read from a file, mm (10 km). A double then still
/// resolves 2e-9 mm, three orders below repair.merge_tolerance_mm (1e-6 mm); an image's
/// origin is held to 1e6 mm by the same reasoning. A vertex at 1e30 mm made remesh pick
/// h = 7.6e27 mm and drop the spike silently.
inline constexpr double max_coordinate_mm = 1e7;

/// Smallest extent of a surface or mesh along its longest axis, mm: the smallest voxel
/// spacing an image may have. A surface scaled by 1e-30 is smaller than every tolerance of
/// the pipeline and was misdiagnosed as open or inverted.
inline constexpr double min_extent_mm = 1e-4;

/// Throws InputError with one line "SOURCE: point I at (x, y, z) mm ..." for the first
/// point (in id order) with a non-finite coordinate or one beyond ±max_coordinate_mm, and
/// "SOURCE: ... mm across ..." when the bounding box of all points is smaller than
/// min_extent_mm along every axis. `xyz` holds 3 coordinates per point, mm; an empty list
/// passes (the readers refuse a file without cells themselves). Cost: one pass, O(points).
void require_coordinates_in_range(const std::vector<double>& xyz, const std::string& source);

}  // namespace frontmesh::core
