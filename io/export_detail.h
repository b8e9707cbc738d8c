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

/// The (region_in, region_out) pairs of mesh.faces, numbered tag = 1, 2, ... in order.
struct SurfaceGroup {
    core::Label in = 0, out = 0;
    int tag = 0;
    std::string name;                 ///< boundary_<in> / interface_<in>_<out>
    std::vector<std::int32_t> faces;  ///< indices into mesh.faces, increasing
};
std::vector<SurfaceGroup> surface_groups(const core::TetMesh& mesh, const LabelTable& names);

/// The region labels of the tets, increasing, and the tets of each (indices, increasing).
struct RegionGroup {
    core::Label label = 0;
    std::string name;
    std::vector<std::int32_t> tets;
};
std::vector<RegionGroup> region_groups(const core::TetMesh& mesh, const LabelTable& names);

/// Sorted, unique nodes of some faces.
std::vector<std::int32_t> face_nodes(const core::TetMesh& mesh,
                                     const std::vector<std::int32_t>& faces);

/// For each face of mesh.faces, the tet of region_in with that face as an outward face and
/// the local face index k (face opposite node k, nodes {1,2,3},{0,3,2},{0,1,3},{0,2,1});
/// {-1, -1} when there is none (the mesh does not keep the face).
std::vector<std::array<std::int32_t, 2>> face_tets(const core::TetMesh& mesh);

void write_msh41(const core::TetMesh& mesh, const std::string& path, const LabelTable& names);
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
    std::string_view rest_of_line();  ///< up to the end of the current line
    void skip_line();
    [[noreturn]] void fail(const std::string& message) const;  ///< InputError "file:line: ..."
    const std::string& text() const { return text_; }
    std::size_t position() const { return pos_; }

private:
    void skip_space();
    std::string path_, text_;
    std::size_t pos_ = 0;
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
