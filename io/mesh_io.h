#pragma once
// Surface meshes in and out: VTU checkpoints, and input surfaces in common formats.

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/core/quality.h"
#include "pipeline/core/stage_context.h"
#include "pipeline/core/surface_network.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::io {

/// Strings recorded in a checkpoint's field data (e.g. "frame" -> "lps", "stage" -> "repair").
using FieldStrings = std::map<std::string, std::string>;

/// Per-point float64 arrays by name (e.g. "target_size" of the remesh checkpoint).
using PointArrays = std::map<std::string, std::vector<double>>;

/// Stops VTK from printing its own error and warning text (process-wide): the command line
/// reports each failure as one line of its own, and the readers and writers turn VTK's
/// error events into those lines. Without it a damaged compressed block printed two
/// coloured log lines of VTK's zlib compressor before frontmesh's error (the malformed-
/// input campaign, issue 21).
void silence_vtk_console();

/// Writes `surface` as a VTK XML unstructured grid of triangles (binary, zlib-compressed),
/// atomically. Cell arrays: `region_in`, `region_out` (int32), `eta` (Eq. 2) and
/// `min_angle` (degrees) (float64). Field data: one string array per entry of `fields`;
/// point data: one array per entry of `point_arrays` (each of vertex_count() values).
/// Throws IoError naming `path` on failure.
void write_surface_vtu(const core::SurfaceNetwork& surface, const std::string& path,
                       const FieldStrings& fields, const PointArrays& point_arrays = {});

/// Reads a triangle surface from .vtu, .vtp, .stl, .off or .ply. Cell arrays `region_in`
/// and `region_out` are used when present; otherwise every face gets region_in = 1,
/// region_out = 0. Field-data strings are returned in `fields` when given. Coincident
/// points are kept as they are (repair merges them). Throws InputError naming the file
/// when it is missing, of an unknown format, empty, has non-triangle cells, or its points
/// are out of range (core::require_coordinates_in_range: beyond 1e7 mm, or all within
/// 1e-4 mm).
core::SurfaceNetwork read_surface(const std::string& path, FieldStrings* fields = nullptr);

/// A colour (sRGB, 0..255) per region label.
using LabelColours = std::map<core::Label, std::array<std::uint8_t, 3>>;

/// Writes `mesh` as a VTK XML unstructured grid of tetrahedra (binary, zlib), atomically.
/// Cell arrays: `region` (int32), `skewness` (Eq. 1) and `min_dihedral` (degrees) (float32,
/// from `figures` when given: core::tet_figures of every tet in order, else computed here);
/// point array `level` (int32) when the mesh has one. A quadratic mesh (mesh.tet_mid) is
/// written as VTK_QUADRATIC_TETRA cells (corners, then the mid nodes of edges 01, 12, 20,
/// 03, 13, 23); figures and colours are of its corner tets. The boundary and interface triangles
/// travel in field data (`boundary_faces` int32 x3, `boundary_region_in`,
/// `boundary_region_out`, `surface_vertices`), so the file holds only tets for ParaView and
/// solvers while read_tet_mesh() restores the whole TetMesh. Field data: one string array
/// per entry of `fields` (a char array: meshio rejects VTK's String type). With `colours`
/// (one per region label of the mesh): the cell array `colour` (uint8 x3, the tet's region
/// colour: ParaView shows it as is with "Map Scalars" off) and the field arrays `label_ids`
/// (int32) and `label_colours` (uint8 x3). Throws IoError naming `path` on failure.
void write_tet_mesh_vtu(const core::TetMesh& mesh, const std::string& path,
                        const FieldStrings& fields,
                        const std::vector<core::TetFigures>* figures = nullptr,
                        const LabelColours* colours = nullptr);

/// Writes the boundary and interface triangles of `mesh` (mesh.faces, in order) as a VTK
/// XML PolyData file (.vtp; binary, zlib), atomically: the nodes of the faces (point array
/// `node`: the node's index in the TetMesh, which is its point index in the VTU), cell
/// arrays `tag` (int64, `face_tags`: one per face), `region_in` and `region_out` (int32)
/// and, with `colours`, `colour` (of region_in) plus the field arrays `label_ids` and
/// `label_colours`. Field data: one vtkStringArray per entry of `fields`, a value per
/// line, which ParaView shows as text. Throws IoError naming `path` on failure.
void write_surface_vtp(const core::TetMesh& mesh, const std::vector<std::int64_t>& face_tags,
                       const std::string& path, const FieldStrings& fields,
                       const LabelColours* colours = nullptr);

/// Reads a tetrahedral mesh from .vtu (as written by write_tet_mesh_vtu, or any VTU of tets:
/// region from a cell array `region` when present, else 1; without boundary field data the
/// boundary faces are derived: faces of one tet, or between tets of different regions).
/// Tets of negative volume are reordered. Quadratic tets (VTK_QUADRATIC_TETRA, output.order
/// 2) are read as their corner tets, the mid nodes left unused (as read_mesh reads Gmsh tet10
/// and Abaqus C3D10). Throws InputError naming the file on bad input, points out of range
/// included (core::require_coordinates_in_range).
core::TetMesh read_tet_mesh(const std::string& path, FieldStrings* fields = nullptr);

/// Writes geometry a stage handed to the diagnostics sink as a VTK XML unstructured grid,
/// atomically: its points, its cells as lines, triangles and tets (2, 3 or 4 points), the
/// cell array `kind` (int32) and, in field data, the text `what` plus one string array per
/// entry of `fields`. Throws IoError naming `path` when it cannot be written, InternalError
/// for a cell of another size or a point id out of range.
void write_diagnostic_vtu(const core::Diagnostic& diagnostic, const std::string& path,
                          const FieldStrings& fields = {});

/// Writes a ParaView collection (.pvd) listing `entries` as (file, name) pairs, in order:
/// `file` is relative to the folder of `path`, `name` labels the dataset. Entry i gets
/// timestep i, so opening the .pvd steps through the run. Written atomically; throws
/// IoError naming `path` on failure.
void write_pvd(const std::string& path,
               const std::vector<std::pair<std::string, std::string>>& entries);

}  // namespace frontmesh::io
