#pragma once
// Tetrahedral meshes to and from solver formats: VTU, Gmsh MSH 4.1 / 2.2, MEDIT .mesh,
// Abaqus .inp, FEBio .feb (write only).
//
// Every writer puts the tets with their region and the boundary / interface triangles of
// mesh.faces, grouped by the unordered pair of labels on their two sides, into the file,
// with the same tag numbers in every format and for every subject (surface_tag below):
//   - a region (tag = label) is a Gmsh 3-D physical group, a MEDIT tet reference, an Abaqus
//     *ELSET, a FEBio part (Elements + SolidDomain + placeholder material), the VTU cell
//     array `region`;
//   - a surface (the boundary of region r: tag r; the interface between labels a < b: tag
//     a * kTagBase + b) is a Gmsh 2-D physical group, a MEDIT triangle reference, an
//     Abaqus *NSET "<name>_NODES" plus element-based *SURFACEs, a FEBio Surface; its name
//     is "boundary_<r>" or "interface_<a>_<b>" (with label numbers for r, a, b where the
//     names would make it longer than 74 characters: Abaqus takes 80, Gmsh 128). Abaqus and FEBio
//     name both sides of an interface: "interface_<x>_<y>" is the faces of x's tets that border y
//     (normals from x into y);
//   - the whole: Abaqus ELSET ALLELEMENTS, *SURFACE "boundary" and NSET "boundary_NODES"
//     (every face whose outside is 0; its "** surface" comment gives kAllTag), FEBio
//     ElementSet "all_elements", Surface "boundary", NodeSet "boundary_NODES". Gmsh and MEDIT
//     keep one group per element (a Gmsh element in two physical groups is duplicated by
//     FEniCSx's gmshio and by MSH 2.2): there the whole mesh is every region and the whole
//     outer boundary is every surface of tag below kTagBase.
// A mesh split by io::split_interfaces (mesh.twin non-empty) is written with its copies as
// nodes of their own and each side of a split interface as its own surface: VTU point
// array `twin`, Gmsh view "twin" ($NodeData), Abaqus node-based slave surface and a
// commented *TIE / *CONTACT PAIR per split interface, FEBio SurfacePair on the two sides.
// Names come from the LabelTable (sanitized), "region_<id>" without one. Node and element
// numbers in the files are 1-based in TetMesh order; tets keep VTK node order (positive
// volume), which is also Gmsh's, MEDIT's, Abaqus C3D4's and FEBio tet4's. Abaqus numbers
// take at most 20 characters (CalculiX's and Abaqus's field width), lines at most 132.
// A quadratic mesh (mesh.tet_mid, output.order 2: volume::elevate_to_quadratic) is written
// with 10-node tets and 6-node surface triangles: VTU cell type 24, Gmsh types 11 and 9
// (Gmsh's tet10 lists the mid nodes of edges 3-4 and 2-4 in that order, VTK the other
// way), Abaqus C3D10 (element-face surfaces as for C3D4; node sets with the mid nodes),
// FEBio tet10 with tri6 facets; MEDIT refuses it (InputError).

#include <cstdint>
#include <string>
#include <vector>

#include "io/label_table.h"
#include "io/mesh_io.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::io {

/// Tag numbers (README "Tag numbers"): region = label; surface between labels a < b (a = 0:
/// the outside) = a * kTagBase + b; the whole mesh / whole outer boundary = kAllTag.
inline constexpr std::int64_t kTagBase = 100000;
inline constexpr std::int64_t kAllTag = kTagBase;
/// Largest smaller label of an interface whose tag fits a signed 32-bit number (Gmsh and
/// MEDIT tags): 21473 * kTagBase + 99999 < 2^31.
inline constexpr core::Label kMaxInterfaceLabel = 21473;

/// The tag of the surface between labels a and b (either order, a != b; 0 = outside):
/// min * kTagBase + max. Injective for labels below kTagBase; fits 32 bits while
/// min <= kMaxInterfaceLabel. The Gmsh and MEDIT writers throw InputError outside that
/// range; Abaqus and FEBio name surfaces instead of numbering them.
std::int64_t surface_tag(core::Label a, core::Label b);

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

/// How write_mesh writes.
struct WriteOptions {
    /// Binary where the format has it: MSH 4.1 (binary mode: 32 B per node and 40 B per
    /// tet, about the size of the text, exact doubles, read without parsing). VTU is always
    /// binary (appended raw, zlib); MSH 2.2, MEDIT, Abaqus and FEBio are always text.
    bool binary = false;
};

/// Writes `mesh` to `path` in `format`, atomically (temp file + rename). `names` names the
/// regions; `fields` are extra strings for VTU field data (the label names are added there
/// as "region_names", one "ID NAME" per line). ASCII for every format but VTU (binary, zlib,
/// via write_tet_mesh_vtu: cell arrays region, skewness, min_dihedral, and colour with the
/// field arrays label_ids / label_colours from `names` or io::default_colour) and, with
/// `options.binary`, MSH 4.1. Gmsh nodes belong to the entity Gmsh would give them: a node
/// on a boundary or interface to a surface entity, an interior node to its region's volume.
/// Cost: O(nodes + tets) time; the text formats take about 60 B per node and 50 B per tet.
/// Throws IoError naming `path` on failure, InternalError for a mesh without tets.
void write_mesh(const core::TetMesh& mesh, const std::string& path, MeshFormat format,
                const LabelTable& names = {}, const FieldStrings& fields = {},
                const WriteOptions& options = {});

/// The file of write_mesh_surface beside "<stem>.vtu": "<stem>_surface.vtp".
std::string surface_file_name(const std::string& stem = "mesh");

/// Writes the boundary and interface triangles of `mesh` (mesh.faces) as a VTK PolyData
/// file for ParaView (io::write_surface_vtp), atomically: cell arrays `tag` (surface_tag of
/// the face's two labels: README "Tag numbers"), `region_in`, `region_out`, `colour` (of
/// region_in); point array `node` (index in the TetMesh / mesh.vtu); field data as text
/// (vtkStringArray, a value per line): `fields`, "region_names" ("ID NAME" per region) and
/// "surface_tags" ("TAG NAME" per surface), plus `label_ids` / `label_colours` (the label
/// table's colours, else io::default_colour). Throws IoError naming `path` on failure.
void write_mesh_surface(const core::TetMesh& mesh, const std::string& path,
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

/// Reads a tetrahedral mesh: .vtu (io::read_tet_mesh), .msh (Gmsh 4.1 ASCII or binary
/// with 8-byte size_t in this machine's byte order, 2.2 ASCII),
/// .mesh (MEDIT, ASCII), .inp (Abaqus C3D4 with *ELSET regions). Regions: Gmsh physical tag
/// (else elementary tag), MEDIT reference, Abaqus element sets (the id in a "region_<id>"
/// name or a "** region <id> <set>" comment written by write_mesh, else 1, 2, ... in file
/// order). Tets of negative volume are reordered. mesh.faces are the file's triangles that
/// are boundary or interface faces of the tets (their orientation kept; region_in is the
/// region of the tet on the side opposite the normal), plus every such face the file lacks
/// (core::derive_boundary_faces). Region names found in the file go to `names`.
/// Throws InputError naming the file (and line where known) on bad or unsupported input
/// (binary MSH 2.2 and binary .mesh; other element types are skipped; a file without tets
/// is an error; points out of range: core::require_coordinates_in_range).
/// With `keep_orientation` tets keep the file's node order even when their volume is
/// negative (for checking a mesh as it is).
core::TetMesh read_mesh(const std::string& path, LabelTable* names = nullptr,
                        MeshReadInfo* info = nullptr, bool keep_orientation = false);

}  // namespace frontmesh::io
