#pragma once
// Tetrahedral meshes to and from solver formats: VTU, Gmsh MSH 4.1 / 2.2, MEDIT .mesh,
// Abaqus .inp, FEBio .feb (write only).
//
// Every writer puts the tets with their region and the boundary / interface triangles of
// mesh.faces, grouped by (region_in, region_out) pair, into the file:
//   - a region is a Gmsh 3-D physical group (tag = label), a MEDIT tet reference (= label),
//     an Abaqus *ELSET, a FEBio part (Elements + SolidDomain + placeholder material);
//   - a (region_in, region_out) pair is a Gmsh 2-D physical group, a MEDIT triangle reference,
//     an Abaqus *NSET + element-based *SURFACE, a FEBio Surface + NodeSet. Pairs are numbered
//     1, 2, ... in increasing (region_in, region_out) order; their names are
//     "boundary_<region>" (region_out 0) and "interface_<region_in>_<region_out>".
// Names come from the LabelTable (sanitized), "region_<id>" without one. Node and element
// numbers in the files are 1-based in TetMesh order; tets keep VTK node order (positive
// volume), which is also Gmsh's, MEDIT's, Abaqus C3D4's and FEBio tet4's.

#include <string>
#include <vector>

#include "io/label_table.h"
#include "io/mesh_io.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::io {

enum class MeshFormat { Vtu, Msh41, Msh22, Medit, Abaqus, Febio };

/// Format from its recipe / command-line name: "vtu", "msh" (= MSH 4.1), "msh41", "msh22",
/// "mesh" (MEDIT), "inp" (Abaqus), "feb" (FEBio). Case-insensitive; a leading '.' is allowed.
/// Throws InputError listing the known names.
MeshFormat format_from_name(const std::string& name);

/// Format from a file name's extension (.vtu, .msh -> MSH 4.1, .mesh, .inp, .feb).
/// Throws InputError naming the file for another extension.
MeshFormat format_from_path(const std::string& path);

/// The recipe name of a format ("vtu", "msh", "msh22", "mesh", "inp", "feb").
std::string format_name(MeshFormat format);

/// Every recipe name, in the order above.
const std::vector<std::string>& format_names();

/// The file name of an export in output.dir: "<stem>.vtu", "<stem>.msh", "<stem>.v22.msh"
/// (MSH 2.2 keeps gmsh's extension but must not overwrite the 4.1 file), "<stem>.mesh",
/// "<stem>.inp", "<stem>.feb".
std::string export_file_name(MeshFormat format, const std::string& stem = "mesh");

/// Writes `mesh` to `path` in `format`, atomically (temp file + rename). `names` names the
/// regions; `fields` are extra strings for VTU field data (the label names are added there
/// as "region_names", one "ID NAME" per line). ASCII for every format but VTU (binary, zlib,
/// via write_tet_mesh_vtu: cell arrays region, skewness, min_dihedral).
/// Cost: O(nodes + tets) time; the text formats take about 60 B per node and 50 B per tet.
/// Throws IoError naming `path` on failure, InternalError for a mesh without tets.
void write_mesh(const core::TetMesh& mesh, const std::string& path, MeshFormat format,
                const LabelTable& names = {}, const FieldStrings& fields = {});

/// What read_mesh found besides the mesh.
struct MeshReadInfo {
    std::string format;                 ///< "vtu", "msh 4.1", "msh 2.2", "mesh", "inp"
    std::size_t file_triangles = 0;     ///< triangles in the file
    std::size_t ignored_triangles = 0;  ///< of those, not a boundary/interface face of the
                                        ///< tets (or repeated): not kept in mesh.faces
    std::size_t derived_faces = 0;      ///< boundary/interface faces not in the file, added
    FieldStrings fields;                ///< VTU field-data strings
};

/// Reads a tetrahedral mesh: .vtu (io::read_tet_mesh), .msh (Gmsh 4.1 or 2.2, ASCII),
/// .mesh (MEDIT, ASCII), .inp (Abaqus C3D4 with *ELSET regions). Regions: Gmsh physical tag
/// (else elementary tag), MEDIT reference, Abaqus element sets (the id in a "region_<id>"
/// name or a "** region <id> <set>" comment written by write_mesh, else 1, 2, ... in file
/// order). Tets of negative volume are reordered. mesh.faces are the file's triangles that
/// are boundary or interface faces of the tets (their orientation kept; region_in is the
/// region of the tet on the side opposite the normal), plus every such face the file lacks
/// (core::derive_boundary_faces). Region names found in the file go to `names`.
/// Throws InputError naming the file (and line where known) on bad or unsupported input
/// (binary .msh/.mesh, other element types are skipped; a file without tets is an error).
/// With `keep_orientation` tets keep the file's node order even when their volume is
/// negative (for checking a mesh as it is).
core::TetMesh read_mesh(const std::string& path, LabelTable* names = nullptr,
                        MeshReadInfo* info = nullptr, bool keep_orientation = false);

}  // namespace frontmesh::io
