#pragma once
// Checks of a file's layout made before a VTK reader sees it (issue 21). VTK's PLY, STL and
// XML readers trust their input: a damaged file can crash them, send them past the end of
// an array or make them allocate gigabytes. Each check here accepts only files the reader
// handles safely, and refuses the rest with an InputError naming the file and the place.

#include <string>

namespace frontmesh::io {

/// Checks a PLY file for what vtkPLYReader (VTK 9.1) reads safely: a well-formed header
/// (format, element, property, comment, obj_info); one "vertex" element with scalar x, y,
/// z; at most one "face" element whose only list is vertex_indices (or vertex_index) of an
/// integer type, at most 255 long, every index naming a vertex; no other element; element
/// lines (text) or bytes (binary) matching the header. Throws InputError naming the file,
/// line or element.
/// Cost: one pass over the file.
void check_ply(const std::string& path);

/// Checks that a binary STL holds the triangles its header counts (vtkSTLReader allocates
/// that count first). Binary and text are told apart as VTK does; a text STL passes.
/// Throws InputError naming the file.
void check_stl(const std::string& path);

/// Checks a VTK XML file (.vtu, .vtp) for what VTK 9.1's readers do not check: every
/// DataArray (and Array) has a known type name and a format (ascii, binary, appended); the
/// headers of binary data (a byte count, or compressed block sizes) fit in the file; each
/// array of a Piece (points, point and cell data, cell offsets and types) and each field
/// array with NumberOfTuples holds at least the values its counts need, ascii values that
/// parse as its type and base64 text without other characters. A file VTK's XML parser
/// cannot parse passes (the reader reports it). Throws InputError naming the file and the
/// array. Cost: parsing the XML once more and one pass over inline data.
void check_vtk_xml(const std::string& path);

}  // namespace frontmesh::io
