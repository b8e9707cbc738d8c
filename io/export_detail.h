#pragma once
// Internals shared by the exporters (io/export_*.cpp); not part of the public API.

#include <array>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "io/export.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::io::detail {

/// Buffered text output to a FILE*, numbers by std::to_chars (shortest round-trip doubles).
class TextOut {
public:
    explicit TextOut(const std::string& path);
    ~TextOut();
    TextOut(const TextOut&) = delete;
    TextOut& operator=(const TextOut&) = delete;

    TextOut& operator<<(std::string_view s) {
        buf_.append(s);
        if (buf_.size() > kFlushAt) flush();
        return *this;
    }
    TextOut& operator<<(char c) {
        buf_.push_back(c);
        return *this;
    }
    TextOut& operator<<(std::int64_t v) { return number(v); }
    TextOut& operator<<(std::int32_t v) { return number(static_cast<std::int64_t>(v)); }
    TextOut& operator<<(std::size_t v) { return number(static_cast<std::int64_t>(v)); }
    TextOut& operator<<(double v) { return number(v); }
    /// `v` in at most `max_chars` characters (>= 9): its shortest round-trip form when that
    /// fits, else the most significant digits that fit (general or scientific notation).
    /// For fixed-width readers such as Abaqus / CalculiX (20 characters per field: at least
    /// 13 significant digits for any finite double, a relative error below 5e-13).
    TextOut& real_within(double v, int max_chars);
    /// `n` raw bytes (binary file sections).
    TextOut& bytes(const void* p, std::size_t n) {
        buf_.append(static_cast<const char*>(p), n);
        if (buf_.size() > kFlushAt) flush();
        return *this;
    }
    /// Flushes and closes; throws IoError naming the file when a write failed.
    void close();

private:
    static constexpr std::size_t kFlushAt = 1 << 20;
    template <class T>
    TextOut& number(T v) {
        char tmp[32];
        const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
        buf_.append(tmp, static_cast<std::size_t>(r.ptr - tmp));
        if (buf_.size() > kFlushAt) flush();
        return *this;
    }
    void flush();
    std::string path_;
    std::FILE* file_ = nullptr;
    std::string buf_;
    bool failed_ = false;
};

/// The surfaces of mesh.faces: one per unordered pair {lo, hi} of the labels on the two
/// sides (lo < hi; lo = 0 for the outside), in increasing (lo, hi) order, tag =
/// io::surface_tag(lo, hi). The faces keep their orientation (region_in may be lo or hi).
struct SurfaceGroup {
    core::Label lo = 0, hi = 0;
    std::int64_t tag = 0;
    std::string name;                 ///< boundary_<hi> / interface_<lo>_<hi>
    std::vector<std::int32_t> faces;  ///< indices into mesh.faces, increasing
    bool split = false;  ///< an interface split by io::split_interfaces (faces once per side)
    bool is_boundary() const { return lo == 0; }
};
std::vector<SurfaceGroup> surface_groups(const core::TetMesh& mesh, const LabelTable& names);

/// The name of the side of `g` that faces out of region `from` (g.lo or g.hi):
/// "interface_<from>_<other>" (the name of an interface as seen from one region), or
/// g.name for a boundary.
std::string side_name(const SurfaceGroup& g, core::Label from, const LabelTable& names);

/// The faces of `g` seen from region `from` (g.lo or g.hi): of a split interface, those of
/// from's side (region_in == from); otherwise all of g.faces.
std::vector<std::int32_t> side_faces(const core::TetMesh& mesh, const SurfaceGroup& g,
                                     core::Label from);

/// The region labels of the tets, increasing, and the tets of each (indices, increasing).
struct RegionGroup {
    core::Label label = 0;
    std::string name;
    std::vector<std::int32_t> tets;
};
std::vector<RegionGroup> region_groups(const core::TetMesh& mesh, const LabelTable& names);

/// Throws InputError naming `what` (a file) when a numeric tag of `groups` or a region
/// label of `regions` is out of the documented range of io::surface_tag (formats that store
/// tags as 32-bit numbers: Gmsh, MEDIT).
void check_numeric_tags(const std::vector<RegionGroup>& regions,
                        const std::vector<SurfaceGroup>& groups, const std::string& what);

/// Sorted, unique nodes of some faces (with their mid nodes for quadratic tets).
std::vector<std::int32_t> face_nodes(const core::TetMesh& mesh,
                                     const std::vector<std::int32_t>& faces);

/// The nodes of tet t: its 4 corners, then (quadratic tets) its 6 mid nodes, in VTK order
/// (core::kTetEdge; Abaqus C3D10 and FEBio tet10 use it too). Returns the count (4 or 10).
inline int tet_nodes(const core::TetMesh& mesh, std::size_t t, std::array<std::int32_t, 10>& v) {
    for (int k = 0; k < 4; ++k) v[static_cast<std::size_t>(k)] = mesh.tets[t][k];
    if (!mesh.is_quadratic()) return 4;
    for (int k = 0; k < 6; ++k) v[static_cast<std::size_t>(4 + k)] = mesh.tet_mid[t][k];
    return 10;
}
/// The nodes of face f: its 3 corners, then (quadratic tets) its 3 mid nodes (edges 01, 12,
/// 20: VTK, Gmsh and FEBio tri6 order). `flip` reverses the orientation (corners 0, 2, 1;
/// mid nodes of edges 02, 21, 10). Returns the count (3 or 6).
inline int face_nodes_of(const core::TetMesh& mesh, std::size_t f, bool flip,
                         std::array<std::int32_t, 6>& v) {
    const auto& c = mesh.faces[f];
    v[0] = c[0];
    v[1] = flip ? c[2] : c[1];
    v[2] = flip ? c[1] : c[2];
    if (!mesh.is_quadratic()) return 3;
    const auto& m = mesh.face_mid[f];
    v[3] = flip ? m[2] : m[0];
    v[4] = m[1];
    v[5] = flip ? m[0] : m[2];
    return 6;
}

/// For each face of mesh.faces, the tet of region_in with that face as an outward face and
/// the local face index k (face opposite node k, nodes {1,2,3},{0,3,2},{0,1,3},{0,2,1}),
/// then the same for the tet of region_out on the other side; {-1, -1} where there is none
/// (the outside, or a mesh that does not keep the face).
struct FaceSides {
    std::array<std::int32_t, 2> in{-1, -1}, out{-1, -1};
};
std::vector<FaceSides> face_tets(const core::TetMesh& mesh);

/// MSH 4.1, ASCII or (`binary`) binary.
void write_msh41(const core::TetMesh& mesh, const std::string& path, const LabelTable& names,
                 bool binary);
void write_msh22(const core::TetMesh& mesh, const std::string& path, const LabelTable& names);
void write_medit(const core::TetMesh& mesh, const std::string& path, const LabelTable& names);
void write_abaqus(const core::TetMesh& mesh, const std::string& path, const LabelTable& names);
void write_febio(const core::TetMesh& mesh, const std::string& path, const LabelTable& names);

/// Whitespace-separated tokens of a text file, with "file:line" in errors.
class Tokens {
public:
    /// Reads the whole file; throws InputError when it cannot be read.
    explicit Tokens(const std::string& path);
    bool at_end();                            ///< only whitespace left
    std::string_view word(const char* what);  ///< next token; throws at the end
    long long integer(const char* what);
    double real(const char* what);
    /// Binary sections (Gmsh MSH 4.1 binary mode): after set_binary(true), real() reads a
    /// native float64 and integer(what, bytes) a native int32 (bytes = 4) or uint64
    /// (bytes = 8) at the current position, without skipping whitespace; in text mode
    /// integer(what, bytes) is integer(what).
    void set_binary(bool on) { binary_ = on; }
    long long integer(const char* what, int bytes);
    std::string_view rest_of_line();  ///< up to the end of the current line
    void skip_line();
    [[noreturn]] void fail(const std::string& message) const;  ///< InputError "file:line: ..."
    const std::string& text() const { return text_; }
    std::size_t position() const { return pos_; }

private:
    void skip_space();
    std::string path_, text_;
    std::size_t pos_ = 0;
    bool binary_ = false;
};

/// A mesh as read from a file, before orientation and faces are settled.
struct RawMesh {
    core::TetMesh mesh;                                  ///< xyz, tets, region
    std::vector<std::array<std::int32_t, 3>> triangles;  ///< as in the file, 0-based
    LabelTable names;
    std::string format;
};
RawMesh read_msh(const std::string& path);
RawMesh read_medit(const std::string& path);
RawMesh read_abaqus(const std::string& path);

}  // namespace frontmesh::io::detail
