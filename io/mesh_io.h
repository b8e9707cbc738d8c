#pragma once
// Surface meshes in and out: VTU checkpoints, and input surfaces in common formats.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/core/surface_network.h"

namespace frontmesh::io {

/// Strings recorded in a checkpoint's field data (e.g. "frame" -> "lps", "stage" -> "repair").
using FieldStrings = std::map<std::string, std::string>;

/// Writes `surface` as a VTK XML unstructured grid of triangles (binary, zlib-compressed),
/// atomically. Cell arrays: `region_in`, `region_out` (int32), `eta` (Eq. 2) and
/// `min_angle` (degrees) (float64). Field data: one string array per entry of `fields`.
/// Throws IoError naming `path` on failure.
void write_surface_vtu(const core::SurfaceNetwork& surface, const std::string& path,
                       const FieldStrings& fields);

/// Reads a triangle surface from .vtu, .vtp, .stl, .off or .ply. Cell arrays `region_in`
/// and `region_out` are used when present; otherwise every face gets region_in = 1,
/// region_out = 0. Field-data strings are returned in `fields` when given. Coincident
/// points are kept as they are (repair merges them). Throws InputError naming the file
/// when it is missing, of an unknown format, empty, or has non-triangle cells.
core::SurfaceNetwork read_surface(const std::string& path, FieldStrings* fields = nullptr);

/// Writes a ParaView collection (.pvd) listing `entries` as (file, name) pairs, in order:
/// `file` is relative to the folder of `path`, `name` labels the dataset. Entry i gets
/// timestep i, so opening the .pvd steps through the run. Written atomically; throws
/// IoError naming `path` on failure.
void write_pvd(const std::string& path,
               const std::vector<std::pair<std::string, std::string>>& entries);

}  // namespace frontmesh::io
