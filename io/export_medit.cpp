// MEDIT .mesh (ASCII, MeshVersionFormatted 2): writer and reader.
// Layout: keyword, count on the next line, then one entity per line ending with its reference.

#include <algorithm>
#include <map>
#include <set>

#include "io/atomic_file.h"
#include "io/export_detail.h"
#include "pipeline/core/error.h"

namespace frontmesh::io::detail {

void write_medit(const core::TetMesh& mesh, const std::string& path, const LabelTable& names) {
    // MEDIT's Tetrahedra are linear; its P2 keywords are not read by the tools .mesh is for.
    if (mesh.is_quadratic())
        FM_THROW(InputError, path +
                                 ": the MEDIT .mesh format holds no quadratic tets "
                                 "(output.order 2); drop mesh from output.formats");
    const auto regions = region_groups(mesh, names);
    const auto surfaces = surface_groups(mesh, names);
    check_numeric_tags(regions, surfaces, path);
    std::vector<std::int64_t> face_ref(mesh.face_count(), 0);
    for (const auto& g : surfaces)
        for (std::int32_t f : g.faces) face_ref[static_cast<std::size_t>(f)] = g.tag;
    write_atomically(path, [&](const std::string& temp) {
        TextOut out(temp);
        out << "MeshVersionFormatted 2\nDimension 3\n";
        out << "# frontmesh: tetrahedron reference = region label, triangle reference = surface\n"
               "# tag (between labels a < b, 0 = outside: a * "
            << kTagBase << " + b)\n";
        for (const auto& r : regions) out << "# region " << r.label << ' ' << r.name << '\n';
        for (const auto& g : surfaces)
            out << "# surface " << g.tag << ' ' << g.name << " (labels " << g.lo << " and " << g.hi
                << ")\n";
        const std::size_t n = mesh.node_count();
        out << "Vertices\n" << n << '\n';
        for (std::size_t v = 0; v < n; ++v)
            out << mesh.xyz[3 * v] << ' ' << mesh.xyz[3 * v + 1] << ' ' << mesh.xyz[3 * v + 2]
                << " 0\n";
        out << "Triangles\n" << mesh.face_count() << '\n';
        for (std::size_t f = 0; f < mesh.face_count(); ++f) {
            const auto& t = mesh.faces[f];
            out << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << ' ' << face_ref[f] << '\n';
        }
        out << "Tetrahedra\n" << mesh.tet_count() << '\n';
        for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
            const auto& q = mesh.tets[t];
            out << q[0] + 1 << ' ' << q[1] + 1 << ' ' << q[2] + 1 << ' ' << q[3] + 1 << ' '
                << mesh.region[t] << '\n';
        }
        out << "End\n";
        out.close();
    });
}

RawMesh read_medit(const std::string& path) {
    Tokens in(path);
    RawMesh raw;
    raw.format = "mesh";
    // Sections to skip: keyword -> numbers per entity.
    static const std::map<std::string, int> skip = {{"Edges", 3},
                                                    {"Quadrilaterals", 5},
                                                    {"Hexahedra", 9},
                                                    {"Hexaedra", 9},
                                                    {"Prisms", 7},
                                                    {"Pyramids", 6},
                                                    {"Corners", 1},
                                                    {"RequiredVertices", 1},
                                                    {"Ridges", 1},
                                                    {"RequiredEdges", 1},
                                                    {"RequiredTriangles", 1},
                                                    {"Normals", 3},
                                                    {"NormalAtVertices", 2},
                                                    {"Tangents", 3},
                                                    {"TangentAtVertices", 2},
                                                    {"Identifier", 0}};
    int dimension = 0;
    bool seen_version = false;
    std::map<long long, std::string> region_names;
    std::set<long long> labels;
    // A section's count: each entity holds `tokens` tokens of at least one byte each, so no
    // more entities than the rest of the file has room for (a count of 8.8e18 made
    // reserve() throw length_error, found by fuzz_mesh; the product for a skipped section
    // overflowed).
    const auto count = [&in](const char* what, int tokens) {
        const long long n = in.integer(what);
        const std::size_t room = in.text().size() - std::min(in.text().size(), in.position());
        if (n < 0 || static_cast<unsigned long long>(n) > room / std::size_t(std::max(tokens, 1)))
            in.fail(std::string(what) + " " + std::to_string(n) +
                    " is more than the rest of the file holds");
        return n;
    };
    while (!in.at_end()) {
        const std::string key(in.word("a keyword"));
        if (key[0] == '#') {
            // "# region <id> <name>" comments written by write_medit carry the region names.
            const std::string rest(in.rest_of_line());
            if (key == "#" && rest.rfind("region ", 0) == 0) {
                const std::size_t sp = rest.find(' ', 7);
                if (sp != std::string::npos) {
                    try {
                        region_names[std::stoll(rest.substr(7, sp - 7))] = rest.substr(sp + 1);
                    } catch (const std::exception&) {
                    }
                }
            }
            in.skip_line();
            continue;
        }
        if (key == "MeshVersionFormatted") {
            const long long v = in.integer("the mesh version");
            if (v < 1 || v > 4)
                in.fail("MeshVersionFormatted " + std::to_string(v) + " is not supported");
            seen_version = true;
        } else if (key == "Dimension") {
            dimension = static_cast<int>(in.integer("the dimension"));
            if (dimension != 3)
                in.fail("only 3-D meshes are supported (Dimension " + std::to_string(dimension) +
                        ")");
        } else if (key == "Vertices") {
            if (!seen_version || dimension != 3)
                in.fail("Vertices before MeshVersionFormatted / Dimension 3");
            const long long n = count("the number of vertices", 4);
            raw.mesh.xyz.reserve(3 * static_cast<std::size_t>(n));
            for (long long i = 0; i < n; ++i) {
                const double x = in.real("a coordinate"), y = in.real("a coordinate"),
                             z = in.real("a coordinate");
                in.integer("a vertex reference");
                raw.mesh.add_node({x, y, z});
            }
        } else if (key == "Triangles") {
            const long long n = count("the number of triangles", 4);
            for (long long i = 0; i < n; ++i) {
                std::array<std::int32_t, 3> t{};
                for (auto& v : t) v = static_cast<std::int32_t>(in.integer("a vertex number") - 1);
                in.integer("a triangle reference");
                raw.triangles.push_back(t);
            }
        } else if (key == "Tetrahedra") {
            const long long n = count("the number of tetrahedra", 5);
            for (long long i = 0; i < n; ++i) {
                std::int32_t t[4];
                for (auto& v : t) v = static_cast<std::int32_t>(in.integer("a vertex number") - 1);
                const long long ref = in.integer("a tetrahedron reference");
                if (ref <= 0 || ref > 2147483647LL)
                    in.fail("tetrahedron " + std::to_string(i + 1) + " has reference " +
                            std::to_string(ref) + " (regions must be > 0)");
                raw.mesh.add_tet(t[0], t[1], t[2], t[3], static_cast<core::Label>(ref));
                labels.insert(ref);
            }
        } else if (key == "End") {
            break;
        } else if (const auto it = skip.find(key); it != skip.end()) {
            if (it->second == 0) {
                in.skip_line();
                continue;
            }
            const long long n = count("a count", it->second);
            for (long long i = 0; i < n * it->second; ++i) in.word("a number");
        } else {
            in.fail("unknown MEDIT keyword \"" + key.substr(0, 40) +
                    "\" (binary .meshb files are not supported)");
        }
    }
    for (const auto& [label, name] : region_names)
        if (labels.count(label) && name != "region_" + std::to_string(label))
            raw.names.set(static_cast<core::Label>(label), name);
    return raw;
}

}  // namespace frontmesh::io::detail
