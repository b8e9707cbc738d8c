#include "io/export.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <unordered_map>

#include <vtkCellArray.h>
#include <vtkCellArrayIterator.h>
#include <vtkNew.h>
#include <vtkSmartPointer.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include "io/atomic_file.h"
#include "io/export_detail.h"
#include "pipeline/core/coordinate_range.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"

namespace frontmesh::io {
namespace {

struct FormatInfo {
    MeshFormat format;
    const char* name;
};
constexpr FormatInfo kFormats[] = {{MeshFormat::Vtu, "vtu"},     {MeshFormat::Msh41, "msh"},
                                   {MeshFormat::Msh22, "msh22"}, {MeshFormat::Medit, "mesh"},
                                   {MeshFormat::Abaqus, "inp"},  {MeshFormat::Febio, "feb"}};

std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

std::string known_names() {
    std::string s;
    for (const auto& f : kFormats) s += (s.empty() ? "" : ", ") + std::string(f.name);
    return s;
}

using Key = std::array<std::int32_t, 3>;
Key sorted_key(const std::array<std::int32_t, 3>& f) {
    Key k = f;
    std::sort(k.begin(), k.end());
    return k;
}
struct KeyHash {
    std::size_t operator()(const Key& k) const noexcept {
        std::uint64_t h = 1469598103934665603ull;
        for (std::int32_t v : k) h = (h ^ static_cast<std::uint32_t>(v)) * 1099511628211ull;
        return static_cast<std::size_t>(h);
    }
};

/// True when (a, b, c) is a cyclic rotation of (x, y, z).
bool same_orientation(const std::array<std::int32_t, 3>& f, const std::array<std::int32_t, 3>& g) {
    for (int r = 0; r < 3; ++r)
        if (f[0] == g[r] && f[1] == g[(r + 1) % 3] && f[2] == g[(r + 2) % 3]) return true;
    return false;
}

/// Orientation, faces and surface_vertices of a mesh read from a solver file.
core::TetMesh settle(detail::RawMesh raw, MeshReadInfo* info, bool keep_orientation) {
    core::TetMesh mesh = std::move(raw.mesh);
    for (auto& t : mesh.tets)
        if (!keep_orientation && core::tet_signed_volume(mesh.point(t[0]), mesh.point(t[1]),
                                                         mesh.point(t[2]), mesh.point(t[3])) < 0)
            std::swap(t[0], t[1]);
    core::derive_boundary_faces(mesh);  // every boundary / interface face, once
    std::unordered_map<Key, std::int32_t, KeyHash> derived;
    derived.reserve(mesh.faces.size());
    for (std::size_t i = 0; i < mesh.faces.size(); ++i)
        derived.emplace(sorted_key(mesh.faces[i]), static_cast<std::int32_t>(i));
    std::vector<char> used(mesh.faces.size(), 0);
    std::vector<std::array<std::int32_t, 3>> faces;
    std::vector<core::Label> in, out;
    std::size_t ignored = 0;
    for (const auto& tri : raw.triangles) {
        const auto it = derived.find(sorted_key(tri));
        if (it == derived.end() || used[static_cast<std::size_t>(it->second)]) {
            ++ignored;
            continue;
        }
        const auto d = static_cast<std::size_t>(it->second);
        used[d] = 1;
        // The derived face points out of its region_in; the file's may point the other way.
        if (same_orientation(tri, mesh.faces[d])) {
            faces.push_back(tri);
            in.push_back(mesh.region_in[d]);
            out.push_back(mesh.region_out[d]);
        } else if (mesh.region_out[d] != 0) {
            faces.push_back(tri);
            in.push_back(mesh.region_out[d]);
            out.push_back(mesh.region_in[d]);
        } else {  // an outer boundary face pointing inwards: keep the outward orientation
            faces.push_back(mesh.faces[d]);
            in.push_back(mesh.region_in[d]);
            out.push_back(0);
        }
    }
    std::size_t added = 0;
    for (std::size_t d = 0; d < mesh.faces.size(); ++d)
        if (!used[d]) {
            faces.push_back(mesh.faces[d]);
            in.push_back(mesh.region_in[d]);
            out.push_back(mesh.region_out[d]);
            ++added;
        }
    mesh.faces = std::move(faces);
    mesh.region_in = std::move(in);
    mesh.region_out = std::move(out);
    // Nodes [0, k) on faces when the file numbers surface nodes first (as write_mesh does).
    std::vector<char> on_face(mesh.node_count(), 0);
    std::int32_t k = 0;
    for (const auto& f : mesh.faces)
        for (std::int32_t v : f) {
            on_face[static_cast<std::size_t>(v)] = 1;
            k = std::max(k, v + 1);
        }
    const bool leading =
        std::all_of(on_face.begin(), on_face.begin() + k, [](char c) { return c != 0; });
    mesh.surface_vertices = leading ? k : static_cast<std::int32_t>(mesh.node_count());
    if (info) {
        info->format = raw.format;
        info->file_triangles = raw.triangles.size();
        info->ignored_triangles = ignored;
        info->derived_faces = added;
    }
    return mesh;
}

std::string region_names_text(const LabelTable& names, const core::TetMesh& mesh) {
    std::vector<core::Label> labels(mesh.region.begin(), mesh.region.end());
    std::sort(labels.begin(), labels.end());
    labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    std::string s;
    for (core::Label l : labels) s += std::to_string(l) + " " + names.name(l) + "\n";
    return s;
}

/// "TAG NAME" per surface, one per line (VTU field data "surface_tags").
std::string surface_tags_text(const LabelTable& names, const core::TetMesh& mesh) {
    std::string s;
    for (const auto& g : detail::surface_groups(mesh, names))
        s += std::to_string(g.tag) + " " + g.name + "\n";
    return s;
}

/// The colour of every label of the tets (and of region_in when `faces`): the table's, else
/// the default palette.
LabelColours label_colours(const core::TetMesh& mesh, const LabelTable& names, bool faces) {
    LabelColours colours;
    for (core::Label l : mesh.region) colours.emplace(l, names.colour(l));
    if (faces)
        for (core::Label l : mesh.region_in) colours.emplace(l, names.colour(l));
    return colours;
}

}  // namespace

std::int64_t surface_tag(core::Label a, core::Label b) {
    FM_CHECK(a != b && a >= 0 && b >= 0);
    return std::int64_t{std::min(a, b)} * kTagBase + std::max(a, b);
}

MeshFormat format_from_name(const std::string& name) {
    std::string n = lower(name);
    if (!n.empty() && n[0] == '.') n.erase(0, 1);
    if (n == "msh41" || n == "msh4") return MeshFormat::Msh41;
    if (n == "msh2") return MeshFormat::Msh22;
    for (const auto& f : kFormats)
        if (n == f.name) return f.format;
    FM_THROW(InputError, "mesh format \"" + name + "\": unknown; known formats: " + known_names());
}

MeshFormat format_from_path(const std::string& path) {
    const std::string ext = lower(std::filesystem::path(path).extension().string());
    if (ext == ".vtu") return MeshFormat::Vtu;
    if (ext == ".msh") return MeshFormat::Msh41;
    if (ext == ".mesh") return MeshFormat::Medit;
    if (ext == ".inp") return MeshFormat::Abaqus;
    if (ext == ".feb") return MeshFormat::Febio;
    FM_THROW(InputError, path + ": unknown mesh file extension \"" + ext +
                             "\" (known: .vtu .msh .mesh .inp .feb)");
}

std::string format_name(MeshFormat format) {
    for (const auto& f : kFormats)
        if (f.format == format) return f.name;
    FM_THROW(InternalError, "unknown MeshFormat");
}

const std::vector<std::string>& format_names() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> v;
        for (const auto& f : kFormats) v.push_back(f.name);
        return v;
    }();
    return names;
}

std::string export_file_name(MeshFormat format, const std::string& stem) {
    switch (format) {
        case MeshFormat::Vtu:
            return stem + ".vtu";
        case MeshFormat::Msh41:
            return stem + ".msh";
        case MeshFormat::Msh22:
            return stem + ".v22.msh";
        case MeshFormat::Medit:
            return stem + ".mesh";
        case MeshFormat::Abaqus:
            return stem + ".inp";
        case MeshFormat::Febio:
            return stem + ".feb";
    }
    FM_THROW(InternalError, "unknown MeshFormat");
}

void write_mesh(const core::TetMesh& mesh, const std::string& path, MeshFormat format,
                const LabelTable& names, const FieldStrings& fields, const WriteOptions& options) {
    FM_CHECK(mesh.tet_count() > 0);
    FM_CHECK(mesh.region.size() == mesh.tet_count());
    FM_CHECK(mesh.region_in.size() == mesh.face_count() &&
             mesh.region_out.size() == mesh.face_count());
    switch (format) {
        case MeshFormat::Vtu: {
            FieldStrings f = fields;
            if (!names.empty()) {
                f["region_names"] = region_names_text(names, mesh);
                f["surface_tags"] = surface_tags_text(names, mesh);
            }
            const LabelColours colours = label_colours(mesh, names, false);
            write_tet_mesh_vtu(mesh, path, f, nullptr, &colours);
            return;
        }
        case MeshFormat::Msh41:
            detail::write_msh41(mesh, path, names, options.binary);
            return;
        case MeshFormat::Msh22:
            detail::write_msh22(mesh, path, names);
            return;
        case MeshFormat::Medit:
            detail::write_medit(mesh, path, names);
            return;
        case MeshFormat::Abaqus:
            detail::write_abaqus(mesh, path, names);
            return;
        case MeshFormat::Febio:
            detail::write_febio(mesh, path, names);
            return;
    }
}

std::string surface_file_name(const std::string& stem) { return stem + "_surface.vtp"; }

void write_mesh_surface(const core::TetMesh& mesh, const std::string& path, const LabelTable& names,
                        const FieldStrings& fields) {
    FM_CHECK(mesh.region_in.size() == mesh.face_count() &&
             mesh.region_out.size() == mesh.face_count());
    std::vector<std::int64_t> tags(mesh.face_count());
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        tags[f] = surface_tag(mesh.region_in[f], mesh.region_out[f]);
    FieldStrings f = fields;
    f["region_names"] = region_names_text(names, mesh);
    f["surface_tags"] = surface_tags_text(names, mesh);
    const LabelColours colours = label_colours(mesh, names, true);
    write_surface_vtp(mesh, tags, path, f, &colours);
}

core::TetMesh read_mesh(const std::string& path, LabelTable* names, MeshReadInfo* info,
                        bool keep_orientation) {
    if (!std::filesystem::is_regular_file(path)) FM_THROW(InputError, path + ": no such file");
    const std::string ext = lower(std::filesystem::path(path).extension().string());
    if (ext == ".vtu") {
        FieldStrings fields;
        core::TetMesh mesh = read_tet_mesh(path, &fields);
        if (keep_orientation) {
            // read_tet_mesh reorders negative tets (swaps nodes 0 and 1, order of cells kept):
            // take the file's node order back.
            vtkNew<vtkXMLUnstructuredGridReader> reader;
            reader->SetFileName(path.c_str());
            reader->Update();
            vtkUnstructuredGrid* grid = reader->GetOutput();
            FM_CHECK(grid != nullptr &&
                     static_cast<std::size_t>(grid->GetNumberOfCells()) == mesh.tet_count());
            auto it = vtkSmartPointer<vtkCellArrayIterator>::Take(grid->GetCells()->NewIterator());
            std::size_t t = 0;
            for (it->GoToFirstCell(); !it->IsDoneWithTraversal(); it->GoToNextCell(), ++t) {
                vtkIdType npts = 0;
                const vtkIdType* pts = nullptr;
                it->GetCurrentCell(npts, pts);
                FM_CHECK(npts == 4 || npts == 10);  // quadratic tets: their corners
                for (int k = 0; k < 4; ++k)
                    mesh.tets[t][static_cast<std::size_t>(k)] = static_cast<std::int32_t>(pts[k]);
            }
        }
        if (names) {
            if (const auto it = fields.find("region_names"); it != fields.end()) {
                std::size_t pos = 0;
                const std::string& s = it->second;
                while (pos < s.size()) {
                    std::size_t end = s.find('\n', pos);
                    if (end == std::string::npos) end = s.size();
                    const std::string line = s.substr(pos, end - pos);
                    const std::size_t sp = line.find(' ');
                    if (sp != std::string::npos) {
                        try {
                            names->set(std::stoi(line.substr(0, sp)), line.substr(sp + 1));
                        } catch (const std::exception&) {
                        }
                    }
                    pos = end + 1;
                }
            }
        }
        if (info) {
            info->format = "vtu";
            info->fields = std::move(fields);
        }
        return mesh;
    }
    detail::RawMesh raw;
    if (ext == ".msh")
        raw = detail::read_msh(path);
    else if (ext == ".mesh")
        raw = detail::read_medit(path);
    else if (ext == ".inp")
        raw = detail::read_abaqus(path);
    else
        FM_THROW(InputError, path + ": cannot read meshes of type \"" + ext +
                                 "\" (known: .vtu .msh .mesh .inp)");
    if (raw.mesh.tet_count() == 0) FM_THROW(InputError, path + ": contains no tetrahedra");
    const std::size_t n = raw.mesh.node_count();
    for (const auto& t : raw.mesh.tets)
        for (std::int32_t v : t)
            if (v < 0 || static_cast<std::size_t>(v) >= n)
                FM_THROW(InputError, path + ": a tetrahedron refers to a node that does not exist");
    for (const auto& t : raw.triangles)
        for (std::int32_t v : t)
            if (v < 0 || static_cast<std::size_t>(v) >= n)
                FM_THROW(InputError, path + ": a triangle refers to a node that does not exist");
    core::require_coordinates_in_range(raw.mesh.xyz, path);
    if (names)
        for (const auto& [label, name] : raw.names.names()) names->set(label, name);
    return settle(std::move(raw), info, keep_orientation);
}

namespace detail {

TextOut::TextOut(const std::string& path) : path_(path) {
    file_ = std::fopen(path.c_str(), "wb");
    if (!file_) FM_THROW(IoError, path + ": cannot open for writing");
    buf_.reserve(kFlushAt + 4096);
}

TextOut::~TextOut() {
    if (file_) std::fclose(file_);
}

TextOut& TextOut::real_within(double v, int max_chars) {
    FM_CHECK(max_chars >= 9 && max_chars <= 32);
    char tmp[40];
    auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
    // Fewer significant digits until it fits: at most 17 rounds, each tries the general form
    // (fixed or scientific, trailing zeros dropped) and the scientific one; 9 characters fit
    // any double with one digit ("-1e-308" is 7).
    for (int p = 17; r.ptr - tmp > max_chars && p >= 1; --p) {
        r = std::to_chars(tmp, tmp + sizeof tmp, v, std::chars_format::general, p);
        if (r.ptr - tmp <= max_chars) break;
        r = std::to_chars(tmp, tmp + sizeof tmp, v, std::chars_format::scientific, p - 1);
    }
    FM_CHECK(r.ptr - tmp <= max_chars);
    buf_.append(tmp, static_cast<std::size_t>(r.ptr - tmp));
    if (buf_.size() > kFlushAt) flush();
    return *this;
}

void TextOut::flush() {
    if (!buf_.empty() && std::fwrite(buf_.data(), 1, buf_.size(), file_) != buf_.size())
        failed_ = true;
    buf_.clear();
}

void TextOut::close() {
    flush();
    const bool bad = std::fclose(file_) != 0 || failed_;
    file_ = nullptr;
    if (bad) FM_THROW(IoError, path_ + ": write failed (disk full?)");
}

Tokens::Tokens(const std::string& path) : path_(path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) FM_THROW(InputError, path + ": cannot be read");
    std::ostringstream s;
    s << in.rdbuf();
    text_ = s.str();
}

void Tokens::skip_space() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
}

bool Tokens::at_end() {
    skip_space();
    return pos_ >= text_.size();
}

std::string_view Tokens::word(const char* what) {
    skip_space();
    if (pos_ >= text_.size()) fail(std::string("file ends where ") + what + " was expected");
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    return std::string_view(text_).substr(start, pos_ - start);
}

long long Tokens::integer(const char* what) {
    const std::string_view w = word(what);
    long long v = 0;
    const auto r = std::from_chars(w.data(), w.data() + w.size(), v);
    if (r.ec != std::errc() || r.ptr != w.data() + w.size()) {
        pos_ -= w.size();
        fail(std::string("expected ") + what + " (a whole number), found \"" +
             std::string(w.substr(0, 40)) + "\"");
    }
    return v;
}

long long Tokens::integer(const char* what, int bytes) {
    if (!binary_) return integer(what);
    FM_CHECK(bytes == 4 || bytes == 8);
    if (pos_ + static_cast<std::size_t>(bytes) > text_.size())
        fail(std::string("file ends where ") + what + " was expected");
    long long v = 0;
    if (bytes == 4) {
        std::int32_t i = 0;
        std::memcpy(&i, text_.data() + pos_, sizeof i);
        v = i;
    } else {
        std::uint64_t u = 0;
        std::memcpy(&u, text_.data() + pos_, sizeof u);
        if (u > static_cast<std::uint64_t>(std::numeric_limits<long long>::max()))
            fail(std::string(what) + " out of range");
        v = static_cast<long long>(u);
    }
    pos_ += static_cast<std::size_t>(bytes);
    return v;
}

double Tokens::real(const char* what) {
    if (binary_) {
        double v = 0;
        if (pos_ + sizeof v > text_.size())
            fail(std::string("file ends where ") + what + " was expected");
        std::memcpy(&v, text_.data() + pos_, sizeof v);
        pos_ += sizeof v;
        return v;
    }
    const std::string_view w = word(what);
    double v = 0;
    const char* first = w.data() + (!w.empty() && w[0] == '+' ? 1 : 0);
    const auto r = std::from_chars(first, w.data() + w.size(), v);
    if (r.ec != std::errc() || r.ptr != w.data() + w.size()) {
        pos_ -= w.size();
        fail(std::string("expected ") + what + " (a number), found \"" +
             std::string(w.substr(0, 40)) + "\"");
    }
    return v;
}

std::string_view Tokens::rest_of_line() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t')) ++pos_;
    const std::size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    std::size_t end = pos_;
    while (end > start && std::isspace(static_cast<unsigned char>(text_[end - 1]))) --end;
    return std::string_view(text_).substr(start, end - start);
}

void Tokens::skip_line() {
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    if (pos_ < text_.size()) ++pos_;
}

void Tokens::fail(const std::string& message) const {
    // At the end of the file, name its last line rather than the empty one after it.
    std::size_t at = std::min(pos_, text_.size());
    while (at > 0 && at == text_.size() && std::isspace(static_cast<unsigned char>(text_[at - 1])))
        --at;
    while (at > 0 && at < pos_ && std::isspace(static_cast<unsigned char>(text_[at - 1]))) --at;
    const std::size_t line =
        1 + static_cast<std::size_t>(
                std::count(text_.begin(), text_.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    FM_THROW(InputError, path_ + ":" + std::to_string(line) + ": " + message);
}

namespace {

/// A surface's name from region names, or from the labels when that is longer than every
/// format takes: Abaqus 80 characters with the longest suffix "_NODES", Gmsh 128.
std::string surface_name(const std::string& kind, core::Label a, core::Label b,
                         const LabelTable& names) {
    constexpr std::size_t kMaxSurfaceName = 80 - 6;
    std::string name = kind;
    if (a != 0) name += "_" + names.safe_name(a);
    name += "_" + names.safe_name(b);
    if (name.size() <= kMaxSurfaceName) return name;
    return kind + (a != 0 ? "_" + std::to_string(a) : "") + "_" + std::to_string(b);
}

}  // namespace

std::vector<SurfaceGroup> surface_groups(const core::TetMesh& mesh, const LabelTable& names) {
    std::map<std::pair<core::Label, core::Label>, std::vector<std::int32_t>> by_pair;
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        const core::Label a = mesh.region_in[f], b = mesh.region_out[f];
        by_pair[{std::min(a, b), std::max(a, b)}].push_back(static_cast<std::int32_t>(f));
    }
    std::vector<SurfaceGroup> groups;
    for (auto& [pair, faces] : by_pair) {
        SurfaceGroup g;
        g.lo = pair.first;
        g.hi = pair.second;
        g.tag = surface_tag(g.lo, g.hi);
        g.name = g.lo == 0 ? surface_name("boundary", 0, g.hi, names)
                           : surface_name("interface", g.lo, g.hi, names);
        g.faces = std::move(faces);
        g.split = !mesh.face_twin.empty() &&
                  std::any_of(g.faces.begin(), g.faces.end(), [&](std::int32_t f) {
                      return mesh.face_twin[static_cast<std::size_t>(f)] >= 0;
                  });
        groups.push_back(std::move(g));
    }
    return groups;
}

std::string side_name(const SurfaceGroup& g, core::Label from, const LabelTable& names) {
    if (g.is_boundary() || from == g.lo) return g.name;
    return surface_name("interface", g.hi, g.lo, names);
}

std::vector<std::int32_t> side_faces(const core::TetMesh& mesh, const SurfaceGroup& g,
                                     core::Label from) {
    if (!g.split) return g.faces;
    std::vector<std::int32_t> faces;
    for (std::int32_t f : g.faces)
        if (mesh.region_in[static_cast<std::size_t>(f)] == from) faces.push_back(f);
    return faces;
}

void check_numeric_tags(const std::vector<RegionGroup>& regions,
                        const std::vector<SurfaceGroup>& groups, const std::string& what) {
    for (const auto& r : regions)
        if (r.label >= kTagBase)
            FM_THROW(InputError, what + ": region label " + std::to_string(r.label) +
                                     " has no tag number (labels below " +
                                     std::to_string(kTagBase) +
                                     " have; relabel, or export .inp / .feb, which name regions)");
    for (const auto& g : groups)
        if (g.lo > kMaxInterfaceLabel)
            FM_THROW(InputError, what + ": the interface between labels " + std::to_string(g.lo) +
                                     " and " + std::to_string(g.hi) +
                                     " has no 32-bit tag number (the smaller label " +
                                     "must be at most " + std::to_string(kMaxInterfaceLabel) +
                                     "; relabel, or export .inp / .feb, which name surfaces)");
}

std::vector<RegionGroup> region_groups(const core::TetMesh& mesh, const LabelTable& names) {
    std::map<core::Label, std::vector<std::int32_t>> by_label;
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        by_label[mesh.region[t]].push_back(static_cast<std::int32_t>(t));
    std::vector<RegionGroup> groups;
    for (auto& [label, tets] : by_label)
        groups.push_back({label, names.safe_name(label), std::move(tets)});
    return groups;
}

std::vector<std::int32_t> face_nodes(const core::TetMesh& mesh,
                                     const std::vector<std::int32_t>& faces) {
    std::vector<std::int32_t> nodes;
    nodes.reserve((mesh.is_quadratic() ? 6 : 3) * faces.size());
    for (std::int32_t f : faces) {
        for (std::int32_t v : mesh.faces[static_cast<std::size_t>(f)]) nodes.push_back(v);
        if (mesh.is_quadratic())
            for (std::int32_t v : mesh.face_mid[static_cast<std::size_t>(f)]) nodes.push_back(v);
    }
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    return nodes;
}

std::vector<FaceSides> face_tets(const core::TetMesh& mesh) {
    static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    // A face of a split interface (mesh.face_twin) is stored once per side and has only its
    // `in` tet; both sides may have the same nodes (where every node of the face stays
    // shared, io::split_interfaces), so a key holds up to two faces.
    const bool split = !mesh.face_twin.empty();
    std::unordered_map<Key, std::array<std::int32_t, 2>, KeyHash> index;
    index.reserve(mesh.face_count());
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        const auto [it, added] =
            index.emplace(sorted_key(mesh.faces[f]), std::array<std::int32_t, 2>{-1, -1});
        it->second[added ? 0 : 1] = static_cast<std::int32_t>(f);
    }
    std::vector<FaceSides> result(mesh.face_count());
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        for (int k = 0; k < 4; ++k) {
            const std::array<std::int32_t, 3> g{
                mesh.tets[t][kFace[k][0]], mesh.tets[t][kFace[k][1]], mesh.tets[t][kFace[k][2]]};
            const auto it = index.find(sorted_key(g));
            if (it == index.end()) continue;
            for (const std::int32_t candidate : it->second) {
                if (candidate < 0) continue;
                const auto f = static_cast<std::size_t>(candidate);
                const bool same = same_orientation(g, mesh.faces[f]);
                if (same && mesh.region_in[f] == mesh.region[t])
                    result[f].in = {static_cast<std::int32_t>(t), k};
                else if (!same && mesh.region_out[f] == mesh.region[t] &&
                         !(split && mesh.face_twin[f] >= 0))
                    result[f].out = {static_cast<std::int32_t>(t), k};
            }
        }
    return result;
}

}  // namespace detail
}  // namespace frontmesh::io
