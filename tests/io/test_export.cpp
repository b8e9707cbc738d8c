// Exports read back by our readers and by the real clients: gmsh (Debian) and python3-meshio.

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "io/export.h"
#include "io/label_table.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/skip.h"

using namespace frontmesh;
namespace fs = std::filesystem;

namespace {

/// A cube of 4^3 Kuhn cells with three regions: z low = 1, z high = 2, and x high = 7
/// (so there are boundaries of three regions and the interfaces 1-2, 1-7, 2-7).
core::TetMesh three_region_cube() {
    core::TetMesh mesh = fixtures::cube_tet_mesh(4, 0.5, true);
    for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
        double cx = 0;
        for (int k = 0; k < 4; ++k) cx += mesh.point(mesh.tets[t][k]).x() / 4;
        if (cx > 1.5) mesh.region[t] = 7;
    }
    core::derive_boundary_faces(mesh);
    // Nodes on faces first (TetMesh: nodes [0, surface_vertices) are the surface's).
    std::vector<std::int32_t> new_id(mesh.node_count(), -1);
    std::int32_t next = 0;
    for (const auto& f : mesh.faces)
        for (std::int32_t v : f)
            if (new_id[static_cast<std::size_t>(v)] < 0)
                new_id[static_cast<std::size_t>(v)] = next++;
    mesh.surface_vertices = next;
    for (auto& id : new_id)
        if (id < 0) id = next++;
    std::vector<double> xyz(mesh.xyz.size());
    for (std::size_t v = 0; v < mesh.node_count(); ++v)
        for (int k = 0; k < 3; ++k)
            xyz[3 * static_cast<std::size_t>(new_id[v]) + k] = mesh.xyz[3 * v + k];
    mesh.xyz = xyz;
    for (auto& t : mesh.tets)
        for (auto& v : t) v = new_id[static_cast<std::size_t>(v)];
    for (auto& f : mesh.faces)
        for (auto& v : f) v = new_id[static_cast<std::size_t>(v)];
    return mesh;
}

io::LabelTable names_for_cube() {
    io::LabelTable names;
    names.set(1, "Grey matter");
    names.set(2, "White-matter (WM)");
    names.set(7, "CSF");
    return names;
}

struct Run {
    int exit_code = -1;
    std::string out;
};

Run run(const std::string& command) {
    Run r;
    std::FILE* p = popen((command + " 2>&1").c_str(), "r");
    if (!p) return r;
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
    const int status = pclose(p);
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

bool have(const std::string& program) { return run("command -v " + program).exit_code == 0; }

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

bool have_meshio() { return run("/usr/bin/python3 -c 'import meshio'").exit_code == 0; }

/// "R a b c d" per tet (nodes sorted, 0-based) and "T tag a b c" per triangle, sorted:
/// the content a reader must reproduce whatever order it uses.
std::vector<std::string> signature(const core::TetMesh& mesh, const std::vector<int>& face_tags) {
    std::vector<std::string> lines;
    for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
        auto q = mesh.tets[t];
        std::sort(q.begin(), q.end());
        lines.push_back("R " + std::to_string(mesh.region[t]) + " " + std::to_string(q[0]) + " " +
                        std::to_string(q[1]) + " " + std::to_string(q[2]) + " " +
                        std::to_string(q[3]));
    }
    for (std::size_t f = 0; f < face_tags.size(); ++f) {
        auto q = mesh.faces[f];
        std::sort(q.begin(), q.end());
        lines.push_back("T " + std::to_string(face_tags[f]) + " " + std::to_string(q[0]) + " " +
                        std::to_string(q[1]) + " " + std::to_string(q[2]));
    }
    std::sort(lines.begin(), lines.end());
    return lines;
}

/// Surface tag per face: io::surface_tag of its two labels (README "Tag numbers").
std::vector<int> pair_tags(const core::TetMesh& mesh) {
    std::vector<int> tags;
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        tags.push_back(static_cast<int>(io::surface_tag(mesh.region_in[f], mesh.region_out[f])));
    return tags;
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> v;
    std::istringstream in(text);
    for (std::string l; std::getline(in, l);)
        if (!l.empty() && (l[0] == 'R' || l[0] == 'T')) v.push_back(l);
    std::sort(v.begin(), v.end());
    return v;
}

/// meshio's view of a file: "N nodes", then R/T lines as in signature(). Regions: the
/// cell data gmsh:physical / medit:ref, or for .inp the element set names mapped by `names`.
std::string meshio_dump(const std::string& path, const std::string& set_to_label,
                        const core::TetMesh& ours) {
    const std::string script = R"PY(
import sys, meshio, numpy as np
m = meshio.read(sys.argv[1])
set_to_label = dict(kv.split('=') for kv in sys.argv[2].split(',') if kv)
print("N", len(m.points))
# Our node numbers by (exact) coordinates: a reader may list the nodes in another order
# (meshio takes MSH 4.1 nodes in file order, entity by entity).
ours = {}
for i, line in enumerate(open(sys.argv[3])):
    ours[tuple(float(x) for x in line.split())] = i
index = [ours.get(tuple(float(x) for x in p), -1) for p in m.points]
key = next((k for k in ("gmsh:physical", "medit:ref") if k in m.cell_data), None)
for i, blk in enumerate(m.cells):
    if blk.type not in ("tetra", "triangle"):
        continue
    if key:
        tags = m.cell_data[key][i]
    else:
        tags = np.zeros(len(blk.data), int)
        for name, sets in m.cell_sets.items():
            if name.upper() in set_to_label and len(sets) > i and sets[i] is not None:
                tags[np.asarray(sets[i], int)] = int(set_to_label[name.upper()])
    for c, t in zip(blk.data, tags):
        c = sorted(index[int(x)] for x in c)
        print(("R" if blk.type == "tetra" else "T"), int(t), *c)
)PY";
    const std::string py = fs::path(path).parent_path() / "dump.py";
    std::ofstream(py) << script;
    const std::string points = fs::path(path).parent_path() / "points.txt";
    {
        std::ofstream out(points);
        out.precision(17);
        for (std::size_t v = 0; v < ours.node_count(); ++v)
            out << ours.xyz[3 * v] << ' ' << ours.xyz[3 * v + 1] << ' ' << ours.xyz[3 * v + 2]
                << '\n';
    }
    const Run r =
        run("/usr/bin/python3 '" + py + "' '" + path + "' '" + set_to_label + "' '" + points + "'");
    INFO(r.out);
    REQUIRE(r.exit_code == 0);
    return r.out;
}

std::size_t meshio_nodes(const std::string& dump) {
    std::istringstream in(dump);
    for (std::string l; std::getline(in, l);)
        if (l.rfind("N ", 0) == 0) return std::stoul(l.substr(2));
    return 0;
}

}  // namespace

TEST_CASE("format names and file names", "[io][export]") {
    CHECK(io::format_from_name("msh") == io::MeshFormat::Msh41);
    CHECK(io::format_from_name("MSH22") == io::MeshFormat::Msh22);
    CHECK(io::format_from_name(".inp") == io::MeshFormat::Abaqus);
    CHECK(io::format_from_name("feb") == io::MeshFormat::Febio);
    CHECK_THROWS_AS(io::format_from_name("stl"), core::InputError);
    CHECK(io::format_from_path("/a/b/x.MESH") == io::MeshFormat::Medit);
    CHECK_THROWS_AS(io::format_from_path("x.obj"), core::InputError);
    for (const auto& name : io::format_names())
        CHECK(io::format_name(io::format_from_name(name)) == name);
    CHECK(io::export_file_name(io::MeshFormat::Msh22) !=
          io::export_file_name(io::MeshFormat::Msh41));
}

TEST_CASE("every format round-trips through read_mesh", "[io][export]") {
    const core::TetMesh mesh = three_region_cube();
    const io::LabelTable names = names_for_cube();
    const std::string dir = fixtures::temp_dir("export_roundtrip");
    for (const auto format : {io::MeshFormat::Vtu, io::MeshFormat::Msh41, io::MeshFormat::Msh22,
                              io::MeshFormat::Medit, io::MeshFormat::Abaqus}) {
        const std::string path = dir + "/" + io::export_file_name(format);
        INFO(path);
        io::write_mesh(mesh, path, format, names);
        io::LabelTable back_names;
        io::MeshReadInfo info;
        const core::TetMesh back = io::read_mesh(path, &back_names, &info);
        REQUIRE(back.node_count() == mesh.node_count());
        CHECK(back.xyz == mesh.xyz);  // shortest round-trip decimal text is exact
        CHECK(back.tets == mesh.tets);
        CHECK(back.region == mesh.region);
        CHECK(back.surface_vertices == mesh.surface_vertices);
        if (format == io::MeshFormat::Abaqus) {
            // .inp keeps no triangles: the faces are derived, the same set with the same pairs.
            auto key = [](const core::TetMesh& m) {
                std::set<std::array<int, 5>> s;
                for (std::size_t f = 0; f < m.face_count(); ++f) {
                    auto q = m.faces[f];
                    std::sort(q.begin(), q.end());
                    s.insert({q[0], q[1], q[2], std::min(m.region_in[f], m.region_out[f]),
                              std::max(m.region_in[f], m.region_out[f])});
                }
                return s;
            };
            CHECK(key(back) == key(mesh));
            CHECK(info.derived_faces == mesh.face_count());
        } else {
            CHECK(back.faces == mesh.faces);
            CHECK(back.region_in == mesh.region_in);
            CHECK(back.region_out == mesh.region_out);
            CHECK(info.ignored_triangles == 0);
            CHECK(info.derived_faces == 0);
        }
        for (core::Label l : {1, 2, 7})
            CHECK(back_names.name(l) ==
                  (format == io::MeshFormat::Vtu ? names.name(l) : names.safe_name(l)));
    }
}

TEST_CASE("read_mesh keeps a file's face orientation and adds missing faces", "[io][export]") {
    core::TetMesh mesh = three_region_cube();
    // Flip every interface face (region_in <-> region_out) and drop the first boundary face.
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        if (mesh.region_out[f] != 0) {
            std::swap(mesh.faces[f][1], mesh.faces[f][2]);
            std::swap(mesh.region_in[f], mesh.region_out[f]);
        }
    std::size_t dropped = 0;
    while (mesh.region_out[dropped] != 0) ++dropped;
    const auto dropped_face = mesh.faces[dropped];
    mesh.faces.erase(mesh.faces.begin() + static_cast<std::ptrdiff_t>(dropped));
    mesh.region_in.erase(mesh.region_in.begin() + static_cast<std::ptrdiff_t>(dropped));
    mesh.region_out.erase(mesh.region_out.begin() + static_cast<std::ptrdiff_t>(dropped));
    const std::string path = fixtures::temp_dir("export_faces") + "/m.msh";
    io::write_mesh(mesh, path, io::MeshFormat::Msh41, {});
    io::MeshReadInfo info;
    const core::TetMesh back = io::read_mesh(path, nullptr, &info);
    CHECK(info.derived_faces == 1);
    REQUIRE(back.face_count() == mesh.face_count() + 1);
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        CHECK(back.faces[f] == mesh.faces[f]);
        CHECK(back.region_in[f] == mesh.region_in[f]);
        CHECK(back.region_out[f] == mesh.region_out[f]);
    }
    auto last = back.faces.back(), want = dropped_face;
    std::sort(last.begin(), last.end());
    std::sort(want.begin(), want.end());
    CHECK(last == want);
}

TEST_CASE("readers reject bad files naming file and line", "[io][export]") {
    const std::string dir = fixtures::temp_dir("export_bad");
    std::ofstream(dir + "/a.msh")
        << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 2 1 2\n3 1 0 2\n1\n2\n0 0 x\n";
    try {
        io::read_mesh(dir + "/a.msh");
        FAIL("no error");
    } catch (const core::InputError& e) {
        CHECK_THAT(e.what(), Catch::Contains("a.msh:9"));
    }
    std::ofstream(dir + "/b.msh") << "$MeshFormat\n4.1 1 8\n$EndMeshFormat\n";
    CHECK_THROWS_WITH(io::read_mesh(dir + "/b.msh"), Catch::Contains("binary"));
    std::ofstream(dir + "/c.mesh")
        << "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 0 0\nEnd\n";
    CHECK_THROWS_WITH(io::read_mesh(dir + "/c.mesh"), Catch::Contains("no tetrahedra"));
    // Counts beyond what the file holds (fuzz_mesh: 8.8e18 vertices made reserve() throw
    // length_error; a skipped section's count times its numbers overflowed).
    std::ofstream(dir + "/e.mesh")
        << "MeshVersionFormatted 2\nDimension 3\nVertices\n8777777777777777770\n0 0 0 0\n";
    CHECK_THROWS_WITH(io::read_mesh(dir + "/e.mesh"),
                      Catch::Contains("e.mesh") && Catch::Contains("more than the rest"));
    std::ofstream(dir + "/f.mesh")
        << "MeshVersionFormatted 2\nDimension 3\nEdges\n4000000000000000000\n1 2 0\n";
    CHECK_THROWS_WITH(io::read_mesh(dir + "/f.mesh"), Catch::Contains("more than the rest"));
    // The malformed-input campaign (issue 21): a MSH 2.2 $Nodes count of 1e9 in a 300-byte
    // file threw bad_alloc (exit 1); in MSH 4.1 the count is not reserved beyond the file.
    std::ofstream(dir + "/g.msh") << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1000000008\n"
                                     "1 0 0 0\n2 1 0 0\n$EndNodes\n";
    CHECK_THROWS_WITH(io::read_mesh(dir + "/g.msh"),
                      Catch::Contains("g.msh:5") && Catch::Contains("more than the rest"));
    std::ofstream(dir + "/h.msh") << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n"
                                     "1 4000000000000000000 1 2\n3 1 0 2\n1\n2\n0 0 0\n";
    CHECK_THROWS_AS(io::read_mesh(dir + "/h.msh"), core::InputError);
    std::ofstream(dir + "/d.inp")
        << "*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=C3D4, ELSET=A\n1, 1, 2, 3, 9\n";
    CHECK_THROWS_AS(io::read_mesh(dir + "/d.inp"), core::InputError);
    CHECK_THROWS_AS(io::read_mesh(dir + "/missing.vtu"), core::InputError);
}

/// The $Nodes of an ASCII MSH 4.1 file: node tag -> (entity dim, entity tag), and the
/// count of node tags listed (a node listed twice shows as a count above the map's size).
struct NodeEntities {
    std::map<long long, std::pair<int, long long>> entity;
    std::size_t listed = 0;
};
NodeEntities msh41_node_entities(const std::string& path) {
    std::ifstream in(path);
    NodeEntities result;
    std::string word;
    while (in >> word && word != "$Nodes") {
    }
    std::size_t blocks = 0, nodes = 0, min_tag = 0, max_tag = 0;
    in >> blocks >> nodes >> min_tag >> max_tag;
    for (std::size_t b = 0; b < blocks && in; ++b) {
        int dim = 0, parametric = 0;
        long long tag = 0;
        std::size_t count = 0;
        in >> dim >> tag >> parametric >> count;
        std::vector<long long> tags(count);
        for (auto& t : tags) in >> t;
        for (std::size_t i = 0; i < 3 * count; ++i) in >> word;  // coordinates
        for (long long t : tags) result.entity[t] = {dim, tag};
        result.listed += count;
    }
    return result;
}

TEST_CASE("MSH 4.1: each node in the entity Gmsh gives it, binary reads the same",
          "[io][export][gmsh]") {
    const core::TetMesh mesh = three_region_cube();
    const io::LabelTable names = names_for_cube();
    const std::string dir = fixtures::temp_dir("export_msh_entities");
    const std::string ascii = dir + "/mesh.msh", binary = dir + "/binary.msh";
    io::write_mesh(mesh, ascii, io::MeshFormat::Msh41, names);
    io::write_mesh(mesh, binary, io::MeshFormat::Msh41, names, {}, {true});
    CHECK_THAT(slurp(binary), Catch::StartsWith("$MeshFormat\n4.1 1 8\n"));
    // The expected entity of each node: a node on a face -> a surface entity (dim 2) that
    // holds a face with it; any other node -> the volume of its region (entity tag = label).
    std::vector<char> on_face(mesh.node_count(), 0);
    for (const auto& f : mesh.faces)
        for (std::int32_t v : f) on_face[static_cast<std::size_t>(v)] = 1;
    std::vector<core::Label> interior_region(mesh.node_count(), -1);
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        for (std::int32_t v : mesh.tets[t])
            if (!on_face[static_cast<std::size_t>(v)])
                interior_region[static_cast<std::size_t>(v)] = mesh.region[t];
    auto check_entities = [&](const NodeEntities& got) {
        CHECK(got.listed == mesh.node_count());  // each node once
        REQUIRE(got.entity.size() == mesh.node_count());
        std::map<long long, std::size_t> per_volume;
        for (std::size_t v = 0; v < mesh.node_count(); ++v) {
            const auto [dim, tag] = got.entity.at(static_cast<long long>(v) + 1);
            INFO("node " << v + 1);
            if (on_face[v]) {
                CHECK(dim == 2);
            } else {
                CHECK(dim == 3);
                CHECK(tag == interior_region[v]);
                ++per_volume[tag];
            }
        }
        // Regions 1 and 2 have interior nodes (region 7 is one cell thick: none), each in
        // its own volume, not all in the first.
        CHECK(per_volume[1] > 0);
        CHECK(per_volume[2] > 0);
        CHECK(per_volume.count(7) == 0);
    };
    check_entities(msh41_node_entities(ascii));
    // Our reader reads the binary file to the mesh of the ASCII one.
    io::LabelTable names_ascii, names_binary;
    const core::TetMesh from_text = io::read_mesh(ascii, &names_ascii);
    const core::TetMesh from_bytes = io::read_mesh(binary, &names_binary);
    CHECK(from_bytes.xyz == from_text.xyz);
    CHECK(from_bytes.tets == from_text.tets);
    CHECK(from_bytes.region == from_text.region);
    CHECK(from_bytes.faces == from_text.faces);
    CHECK(from_bytes.region_in == from_text.region_in);
    CHECK(from_text.xyz == mesh.xyz);
    CHECK(names_binary.names() == names_ascii.names());
    // A cut binary file is an InputError naming it, not a crash.
    const std::string cut = dir + "/cut.msh";
    std::ofstream(cut, std::ios::binary) << slurp(binary).substr(0, slurp(binary).size() / 2);
    CHECK_THROWS_AS(io::read_mesh(cut), core::InputError);
    if (!have("gmsh")) {
        FM_SKIP("gmsh not installed (scripts/install-deps.sh installs it)");
    }
    // gmsh keeps the classification (its re-save lists per entity what getNodes(dim, tag)
    // returns), and reads the binary file to the very same model.
    const std::string from_ascii = dir + "/gmsh-ascii.msh", from_binary = dir + "/gmsh-bin.msh";
    for (const auto& [in, out] : {std::pair{ascii, from_ascii}, std::pair{binary, from_binary}}) {
        const Run save = run("gmsh '" + in + "' -0 -format msh41 -o '" + out + "'");
        INFO(save.out);
        REQUIRE(save.exit_code == 0);
        CHECK_THAT(save.out, !Catch::Contains("Error"));
    }
    check_entities(msh41_node_entities(from_ascii));
    CHECK(slurp(from_binary) == slurp(from_ascii));
    if (have_meshio()) {
        // meshio reads the binary file to the same points, cells and physical tags.
        const std::string dump =
            "import meshio, sys\n"
            "m = meshio.read(sys.argv[1])\n"
            "print(repr(m.points.tolist()))\n"
            "for c, t in zip(m.cells, m.cell_data['gmsh:physical']):\n"
            "    print(c.type, c.data.tolist(), t.tolist())\n";
        const Run a = run("/usr/bin/python3 -c \"" + dump + "\" '" + ascii + "'");
        const Run b = run("/usr/bin/python3 -c \"" + dump + "\" '" + binary + "'");
        INFO(a.out << b.out);
        REQUIRE(a.exit_code == 0);
        REQUIRE(b.exit_code == 0);
        CHECK(a.out == b.out);
    }
}

TEST_CASE("gmsh reads the MSH 4.1, MSH 2.2 and MEDIT exports", "[io][export][gmsh]") {
    if (!have("gmsh")) {
        FM_SKIP("gmsh not installed (scripts/install-deps.sh installs it)");
    }
    const core::TetMesh mesh = three_region_cube();
    const io::LabelTable names = names_for_cube();
    const std::string dir = fixtures::temp_dir("export_gmsh");
    const std::vector<std::string> want = signature(mesh, pair_tags(mesh));
    for (const auto format :
         {io::MeshFormat::Msh41, io::MeshFormat::Msh22, io::MeshFormat::Medit}) {
        const std::string path = dir + "/" + io::export_file_name(format);
        INFO(path);
        io::write_mesh(mesh, path, format, names);
        // gmsh -check reports the node and element counts it read.
        const Run check = run("gmsh -check '" + path + "'");
        INFO(check.out);
        REQUIRE(check.exit_code == 0);
        CHECK_THAT(check.out, !Catch::Contains("Error"));
        std::smatch m;
        REQUIRE(std::regex_search(check.out, m, std::regex("(\\d+) nodes")));
        CHECK(std::stoul(m[1]) == mesh.node_count());
        REQUIRE(std::regex_search(check.out, m, std::regex("(\\d+) elements")));
        CHECK(std::stoul(m[1]) == mesh.tet_count() + mesh.face_count());
        // gmsh's own re-export (MSH 2.2) holds the same tets, triangles and physical tags.
        const std::string resaved = dir + "/gmsh-resaved.msh";
        const Run save = run("gmsh '" + path + "' -0 -format msh22 -o '" + resaved + "'");
        INFO(save.out);
        REQUIRE(save.exit_code == 0);
        io::MeshReadInfo info;
        const core::TetMesh back = io::read_mesh(resaved, nullptr, &info);
        CHECK(back.node_count() == mesh.node_count());
        CHECK(back.tet_count() == mesh.tet_count());
        CHECK(info.file_triangles == mesh.face_count());
        // Map gmsh's nodes to ours by their (exact) coordinates before comparing.
        std::map<std::array<double, 3>, std::int32_t> ours;
        for (std::size_t v = 0; v < mesh.node_count(); ++v)
            ours[{mesh.xyz[3 * v], mesh.xyz[3 * v + 1], mesh.xyz[3 * v + 2]}] =
                static_cast<std::int32_t>(v);
        std::vector<std::int32_t> to_ours(back.node_count(), -1);
        for (std::size_t v = 0; v < back.node_count(); ++v) {
            const auto it = ours.find({back.xyz[3 * v], back.xyz[3 * v + 1], back.xyz[3 * v + 2]});
            if (it != ours.end()) to_ours[v] = it->second;
        }
        REQUIRE(std::count(to_ours.begin(), to_ours.end(), -1) == 0);
        std::vector<int> tags;
        {
            // Re-read the triangles' physical tags from gmsh's file with our reader's order.
            std::ifstream in(resaved);
            std::string line;
            while (std::getline(in, line) && line != "$Elements") {
            }
            std::getline(in, line);
            const int n = std::stoi(line);
            std::map<std::array<int, 3>, int> tag_of;
            for (int i = 0; i < n; ++i) {
                std::getline(in, line);
                std::istringstream s(line);
                int id, type, ntags, phys, elem;
                s >> id >> type >> ntags >> phys >> elem;
                if (type != 2) continue;
                std::array<int, 3> q{};
                for (auto& v : q) s >> v, --v;
                std::sort(q.begin(), q.end());
                tag_of[q] =
                    phys != 0 ? phys : elem;  // gmsh keeps MEDIT references as elementary tags
            }
            for (std::size_t f = 0; f < back.face_count(); ++f) {
                auto q = back.faces[f];
                std::sort(q.begin(), q.end());
                tags.push_back(tag_of.count(q) ? tag_of[q] : -1);
            }
        }
        core::TetMesh mapped = back;
        for (auto& q : mapped.tets)
            for (auto& v : q) v = to_ours[static_cast<std::size_t>(v)];
        for (auto& q : mapped.faces)
            for (auto& v : q) v = to_ours[static_cast<std::size_t>(v)];
        const auto got = signature(mapped, tags);
        std::vector<std::string> missing, extra;
        std::set_difference(want.begin(), want.end(), got.begin(), got.end(),
                            std::back_inserter(missing));
        std::set_difference(got.begin(), got.end(), want.begin(), want.end(),
                            std::back_inserter(extra));
        INFO("missing " << missing.size() << (missing.empty() ? "" : ": " + missing[0])
                        << ", extra " << extra.size() << (extra.empty() ? "" : ": " + extra[0]));
        CHECK(got == want);
    }
}

TEST_CASE("meshio reads the msh, mesh, inp and vtu exports", "[io][export][meshio]") {
    if (!have_meshio()) {
        FM_SKIP("python3-meshio not installed (scripts/install-deps.sh installs it)");
    }
    const core::TetMesh mesh = three_region_cube();
    const io::LabelTable names = names_for_cube();
    const std::string dir = fixtures::temp_dir("export_meshio");
    std::string set_to_label;
    for (core::Label l : {1, 2, 7}) {
        std::string upper = names.safe_name(l);
        for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
        set_to_label += (set_to_label.empty() ? "" : ",") + upper + "=" + std::to_string(l);
    }
    const std::vector<std::string> with_faces = signature(mesh, pair_tags(mesh));
    const std::vector<std::string> tets_only = signature(mesh, {});
    for (const auto format : {io::MeshFormat::Msh41, io::MeshFormat::Msh22, io::MeshFormat::Medit,
                              io::MeshFormat::Abaqus}) {
        const std::string path = dir + "/" + io::export_file_name(format);
        INFO(path);
        io::write_mesh(mesh, path, format, names);
        const std::string dump = meshio_dump(path, set_to_label, mesh);
        CHECK(meshio_nodes(dump) == mesh.node_count());
        CHECK(lines_of(dump) == (format == io::MeshFormat::Abaqus ? tets_only : with_faces));
    }
    // VTU: tets with the cell array "region". Without label names: meshio 5.0 cannot read
    // string field arrays (<Array type="String">) in VTK's appended raw layout.
    const std::string vtu = dir + "/mesh.vtu";
    io::write_mesh(mesh, vtu, io::MeshFormat::Vtu, {});
    const Run r =
        run("/usr/bin/python3 -c \"import meshio,sys; m=meshio.read(sys.argv[1]); "
            "print(len(m.points), sum(len(c.data) for c in m.cells if c.type=='tetra'), "
            "sorted(set(int(x) for x in m.cell_data['region'][0])))\" '" +
            vtu + "'");
    INFO(r.out);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.out, Catch::Contains(std::to_string(mesh.node_count()) + " " +
                                      std::to_string(mesh.tet_count()) + " [1, 2, 7]"));
}

TEST_CASE("ParaView files: region colours in the VTU, mesh_surface.vtp with tags and text",
          "[io][export][vtu]") {
    if (run("/usr/bin/python3 -c 'import vtk'").exit_code != 0) {
        FM_SKIP("python3-vtk not installed");
    }
    const core::TetMesh mesh = three_region_cube();
    io::LabelTable names = names_for_cube();
    names.set_colour(2, {250, 250, 250});  // from the table; 1 and 7 take the palette
    const std::string dir = fixtures::temp_dir("export_paraview");
    const std::string vtu = dir + "/mesh.vtu", vtp = dir + "/" + io::surface_file_name();
    CHECK(io::surface_file_name() == "mesh_surface.vtp");
    const io::FieldStrings fields = {{"frame", "lps"}, {"frontmesh_version", "9.9"}};
    io::write_mesh(mesh, vtu, io::MeshFormat::Vtu, names, fields);
    io::write_mesh_surface(mesh, vtp, names, fields);
    const std::string py = R"PY(
import sys, vtk
def read(reader, f):
    r = reader(); r.SetFileName(f); r.Update(); return r.GetOutput()
def colour(a, i):
    return tuple(int(a.GetComponent(i, k)) for k in range(3))
g = read(vtk.vtkXMLUnstructuredGridReader, sys.argv[1])
c, region = g.GetCellData().GetArray('colour'), g.GetCellData().GetArray('region')
print('vtu colours', sorted({(int(region.GetValue(i)),) + colour(c, i)
                             for i in range(g.GetNumberOfCells())}))
ids, table = g.GetFieldData().GetArray('label_ids'), g.GetFieldData().GetArray('label_colours')
print('vtu table', [(int(ids.GetValue(i)),) + colour(table, i)
                    for i in range(ids.GetNumberOfTuples())])
s = read(vtk.vtkXMLPolyDataReader, sys.argv[2])
cd = s.GetCellData()
tag, rin, rout = (cd.GetArray(n) for n in ('tag', 'region_in', 'region_out'))
node = s.GetPointData().GetArray('node')
print('vtp triangles', s.GetNumberOfCells(), 'points', s.GetNumberOfPoints())
bad = 0
for i in range(s.GetNumberOfCells()):
    a, b = sorted((int(rin.GetValue(i)), int(rout.GetValue(i))))
    bad += int(tag.GetValue(i)) != a * 100000 + b
    ids_ = s.GetCell(i).GetPointIds()
    p = [g.GetPoint(int(node.GetValue(ids_.GetId(k)))) for k in range(3)]
    q = [s.GetPoint(ids_.GetId(k)) for k in range(3)]
    bad += p != q
print('vtp bad', bad)
fd = s.GetFieldData()
for n in ('frame', 'frontmesh_version', 'region_names', 'surface_tags'):
    a = fd.GetAbstractArray(n)
    print('text', n, a.GetClassName(), [a.GetValue(i) for i in range(a.GetNumberOfValues())])
)PY";
    std::ofstream(dir + "/check.py") << py;
    const Run r = run("/usr/bin/python3 '" + dir + "/check.py' '" + vtu + "' '" + vtp + "'");
    INFO(r.out);
    REQUIRE(r.exit_code == 0);
    const auto [r1, g1, b1] = io::default_colour(1);
    const auto [r7, g7, b7] = io::default_colour(7);
    const std::string c1 =
        std::to_string(r1) + ", " + std::to_string(g1) + ", " + std::to_string(b1);
    const std::string c7 =
        std::to_string(r7) + ", " + std::to_string(g7) + ", " + std::to_string(b7);
    CHECK_THAT(r.out, Catch::Contains("vtu colours [(1, " + c1 + "), (2, 250, 250, 250), (7, " +
                                      c7 + ")]\n"));
    CHECK_THAT(r.out, Catch::Contains("vtu table [(1, " + c1 + "), (2, 250, 250, 250), (7, " + c7 +
                                      ")]\n"));
    CHECK_THAT(r.out,
               Catch::Contains("vtp triangles " + std::to_string(mesh.face_count()) + " points "));
    CHECK_THAT(r.out, Catch::Contains("vtp bad 0\n"));
    CHECK_THAT(r.out, Catch::Contains("text frame vtkStringArray ['lps']\n"));
    CHECK_THAT(r.out, Catch::Contains("text frontmesh_version vtkStringArray ['9.9']\n"));
    CHECK_THAT(r.out, Catch::Contains("text region_names vtkStringArray ['1 Grey matter', "
                                      "'2 White-matter (WM)', '7 CSF']\n"));
    CHECK_THAT(r.out, Catch::Contains("'100002 interface_Grey_matter_White_matter_WM'"));
    // meshio still reads the VTU (its text stays a char array: meshio rejects VTK strings).
    if (have_meshio()) {
        const Run m =
            run("/usr/bin/python3 -c \"import meshio, sys; m = meshio.read(sys.argv[1]); "
                "print(len(m.points), len(m.cells_dict['tetra']), "
                "m.cell_data['colour'][0].shape)\" '" +
                vtu + "'");
        INFO(m.out);
        CHECK(m.exit_code == 0);
        CHECK_THAT(m.out, Catch::Contains(std::to_string(mesh.node_count()) + " " +
                                          std::to_string(mesh.tet_count()) + " (" +
                                          std::to_string(mesh.tet_count()) + ", 3)"));
    }
}

TEST_CASE("FEBio export: parts, domains, placeholder materials and surfaces",
          "[io][export][febio]") {
    if (run("/usr/bin/python3 -c 'import xml.etree.ElementTree'").exit_code != 0) {
        FM_SKIP("python3 not installed");
    }
    const core::TetMesh mesh = three_region_cube();
    const io::LabelTable names = names_for_cube();
    const std::string path = fixtures::temp_dir("export_febio") + "/mesh.feb";
    io::write_mesh(mesh, path, io::MeshFormat::Febio, names);
    // No FEBio binary here: an XML parser checks the structure and the counts.
    const Run r = run(
        "/usr/bin/python3 -c \"import sys, xml.etree.ElementTree as E\n"
        "r = E.parse(sys.argv[1]).getroot()\n"
        "assert r.tag == 'febio_spec' and r.get('version') == '4.0'\n"
        "print('nodes', len(r.findall('Mesh/Nodes/node')))\n"
        "for e in r.findall('Mesh/Elements'): print('part', e.get('name'), e.get('type'), len(e))\n"
        "for m in r.findall('Material/material'): print('material', m.get('name'))\n"
        "for d in r.findall('MeshDomains/SolidDomain'): print('domain', d.get('name'), "
        "d.get('mat'))\n"
        "for s in r.findall('Mesh/Surface'): print('surface', s.get('name'), "
        "len(s.findall('tri3')))\n"
        "for s in r.findall('Mesh/ElementSet'): print('elementset', s.get('name'), s.text)\n"
        "for s in r.findall('Mesh/NodeSet'): print('nodeset', s.get('name'), "
        "len(s.text.split(',')))\n"
        "\" '" +
        path + "'");
    INFO(r.out);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.out, Catch::Contains("nodes " + std::to_string(mesh.node_count()) + "\n"));
    CHECK_THAT(r.out, Catch::Contains(
                          "elementset all_elements 1:" + std::to_string(mesh.tet_count()) + "\n"));
    std::map<core::Label, std::size_t> per_region;
    for (core::Label l : mesh.region) ++per_region[l];
    for (const auto& [label, count] : per_region) {
        const std::string name = names.safe_name(label);
        CHECK_THAT(r.out,
                   Catch::Contains("part " + name + " tet4 " + std::to_string(count) + "\n"));
        CHECK_THAT(r.out, Catch::Contains("material " + name + "\n"));
        CHECK_THAT(r.out, Catch::Contains("domain " + name + " " + name + "\n"));
    }
    // Boundaries once, interfaces from both sides, the whole outer boundary once.
    std::map<std::pair<int, int>, std::size_t> per_pair;
    std::size_t outer = 0;
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        const int a = mesh.region_in[f], b = mesh.region_out[f];
        ++per_pair[{std::min(a, b), std::max(a, b)}];
        outer += b == 0 ? 1 : 0;
    }
    for (const auto& [pair, count] : per_pair) {
        std::string n = " ";
        n += std::to_string(count);
        n += '\n';
        if (pair.first == 0) {
            CHECK_THAT(r.out,
                       Catch::Contains("surface boundary_" + names.safe_name(pair.second) + n));
        } else {
            const std::string a = names.safe_name(pair.first), b = names.safe_name(pair.second);
            CHECK_THAT(r.out, Catch::Contains("surface interface_" + a + "_" + b + n));
            CHECK_THAT(r.out, Catch::Contains("surface interface_" + b + "_" + a + n));
        }
    }
    CHECK_THAT(r.out, Catch::Contains("surface boundary " + std::to_string(outer) + "\n"));
    CHECK_THAT(r.out, Catch::Contains("nodeset boundary_NODES "));
}

TEST_CASE("FEBio export: a complete FEBio 4 model by the structural check", "[io][export][febio]") {
    if (run("/usr/bin/python3 -c 'import xml.etree.ElementTree'").exit_code != 0) {
        FM_SKIP("python3 not installed");
    }
    const core::TetMesh mesh = three_region_cube();
    const io::LabelTable names = names_for_cube();
    const std::string dir = fixtures::temp_dir("export_febio_check");
    const std::string path = dir + "/mesh.feb";
    io::write_mesh(mesh, path, io::MeshFormat::Febio, names);
    const std::string check = "/usr/bin/python3 '" FRONTMESH_SOURCE_DIR "/tests/io/check_feb.py' ";
    const Run r = run(check + "'" + path + "'");
    INFO(r.out);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.out, Catch::Contains("count nodes " + std::to_string(mesh.node_count()) + "\n"));
    CHECK_THAT(r.out, Catch::Contains("count elements " + std::to_string(mesh.tet_count()) + "\n"));
    CHECK_THAT(r.out, Catch::Contains("count ElementSet all_elements " +
                                      std::to_string(mesh.tet_count()) + "\n"));
    // A PartList of the three parts (FEBio 4.3+), names comma-separated without spaces.
    CHECK_THAT(r.out, Catch::Contains("count PartList all_parts 3\n"));
    // A SurfacePair per interface (1-2, 1-7, 2-7), naming its two sides.
    CHECK_THAT(r.out, Catch::Contains("count pairs 3\n"));
    const std::string text = slurp(path);
    CHECK_THAT(text, Catch::Contains("<SurfacePair name=\"interface_Grey_matter_CSF_PAIR\">\n"
                                     "\t\t\t<primary>interface_Grey_matter_CSF</primary>\n"
                                     "\t\t\t<secondary>interface_CSF_Grey_matter</secondary>"));
    CHECK_THAT(text, Catch::Contains("<units>mm-N-s</units>"));
    CHECK_THAT(text, Catch::Contains("PLACEHOLDER material, units MPa"));

    // The check finds what FEBio would reject: a part without a domain, a pair naming a
    // missing surface, a face on a missing node.
    const std::vector<std::pair<std::string, std::string>> broken = {
        {"<SolidDomain name=\"CSF\" mat=\"CSF\"/>", ""},
        {"<secondary>interface_CSF_Grey_matter</secondary>", "<secondary>nothing</secondary>"},
        {"<tri3 id=\"1\">", "<tri3 id=\"1\">99999,"},
        {"<PartList name=\"all_parts\">", "<PartList name=\"all_parts\">nothing,"}};
    for (const auto& [from, to] : broken) {
        INFO(from);
        std::string bad = text;
        const auto at = bad.find(from);
        REQUIRE(at != std::string::npos);
        bad.replace(at, from.size(), to);
        const std::string bad_path = dir + "/bad.feb";
        std::ofstream(bad_path) << bad;
        const Run b = run(check + "'" + bad_path + "'");
        CHECK(b.exit_code != 0);
        CHECK_THAT(b.out, Catch::Contains("FAIL:"));
    }
}

TEST_CASE("Abaqus surfaces: both sides of interfaces, the outer boundary", "[io][export]") {
    const core::TetMesh mesh = three_region_cube();
    const std::string path = fixtures::temp_dir("export_abaqus") + "/mesh.inp";
    io::write_mesh(mesh, path, io::MeshFormat::Abaqus, {});
    // Count the faces listed in the element sets of each surface and compare with the pairs.
    std::ifstream in(path);
    std::map<std::string, std::size_t> set_size;
    std::map<std::string, std::vector<std::string>> surface_sets;
    std::string line, current, surface;
    while (std::getline(in, line)) {
        if (line.rfind("*ELSET, ELSET=", 0) == 0) {
            current = line.substr(14);
            surface.clear();
        } else if (line.rfind("*SURFACE", 0) == 0) {
            surface = line.substr(line.find("NAME=") + 5);
            current.clear();
        } else if (line[0] == '*') {
            current.clear();
            surface.clear();
        } else if (!current.empty() && line.rfind("**", 0) != 0) {
            set_size[current] +=
                static_cast<std::size_t>(std::count(line.begin(), line.end(), ',')) + 1;
        } else if (!surface.empty()) {
            surface_sets[surface].push_back(line.substr(0, line.find(',')));
        }
    }
    // Each surface, from each side of an interface, and the whole outer boundary: the faces
    // of its element sets are the faces of the pair (or of every boundary).
    std::map<std::string, std::size_t> want;
    auto region = [](int l) { return "region_" + std::to_string(l); };
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        const int a = mesh.region_in[f], b = mesh.region_out[f];
        if (b == 0) {
            ++want["boundary_" + region(a)];
            ++want["boundary"];
        } else {
            ++want["interface_" + region(a) + "_" + region(b)];
            ++want["interface_" + region(b) + "_" + region(a)];
        }
    }
    REQUIRE(surface_sets.size() == want.size());
    for (const auto& [name, count] : want) {
        INFO(name);
        REQUIRE(surface_sets.count(name));
        std::size_t faces = 0;
        for (const auto& s : surface_sets[name]) faces += set_size[s];
        CHECK(faces == count);
    }
}

TEST_CASE("Abaqus numbers fit 20 characters and lines 132, values within 1e-12", "[io][export]") {
    // Issue 22 item 1: CalculiX rejected "-3.414937065768231e-05" (22 characters).
    core::TetMesh mesh = three_region_cube();
    const double hard[] = {-3.414937065768231e-05,
                           -1.2345678901234567e-300,
                           123456.78901234567,
                           -0.00012345678901234567,
                           1.0 / 3.0,
                           -2.0 / 3.0 * 1e-7};
    for (std::size_t i = 0; i < mesh.xyz.size(); ++i)
        mesh.xyz[i] += i < std::size(hard) ? hard[i] : 1e-9 * static_cast<double>(i % 977) / 7.0;
    const std::string path = fixtures::temp_dir("export_abaqus_numbers") + "/mesh.inp";
    io::write_mesh(mesh, path, io::MeshFormat::Abaqus, names_for_cube());
    std::ifstream in(path);
    std::string line;
    bool in_nodes = false;
    std::size_t nodes = 0;
    while (std::getline(in, line)) {
        INFO(line);
        CHECK(line.size() <= 132);
        if (line[0] == '*') {
            in_nodes = line.rfind("*NODE", 0) == 0;
            continue;
        }
        if (!in_nodes) continue;
        ++nodes;
        std::istringstream fields(line);
        for (std::string field; std::getline(fields, field, ',');) {
            while (!field.empty() && field.front() == ' ') field.erase(0, 1);
            CHECK(field.size() <= 20);
        }
    }
    CHECK(nodes == mesh.node_count());
    // The hard values move a few nodes far enough to invert tets: keep the file's order.
    const core::TetMesh back = io::read_mesh(path, nullptr, nullptr, true);
    REQUIRE(back.xyz.size() == mesh.xyz.size());
    for (std::size_t i = 0; i < mesh.xyz.size(); ++i) {
        INFO(i << ": " << mesh.xyz[i] << " read back as " << back.xyz[i]);
        CHECK(std::abs(back.xyz[i] - mesh.xyz[i]) <= 1e-12 * std::abs(mesh.xyz[i]));
    }
    CHECK(back.tets == mesh.tets);
}

TEST_CASE("tags do not depend on which other labels a run meshes", "[io][export]") {
    // Issue 22 item 3: the same interface got tag 4 in one run and 3 in another.
    const core::TetMesh all = three_region_cube();  // labels 1, 2, 7
    core::TetMesh subset;                           // labels 2, 7 only
    {
        core::TetMesh m;
        m.xyz = all.xyz;
        for (std::size_t t = 0; t < all.tet_count(); ++t)
            if (all.region[t] != 1)
                m.add_tet(all.tets[t][0], all.tets[t][1], all.tets[t][2], all.tets[t][3],
                          all.region[t]);
        core::derive_boundary_faces(m);
        m.surface_vertices = static_cast<std::int32_t>(m.node_count());  // not renumbered
        subset = m;
    }
    const io::LabelTable names = names_for_cube();
    const std::string dir = fixtures::temp_dir("export_stable_tags");
    // name -> "dim tag" from $PhysicalNames, and name -> tag from the inp/feb comments.
    auto physical = [](const std::string& path) {
        std::map<std::string, std::string> tags;
        std::ifstream in(path);
        std::string line;
        while (std::getline(in, line) && line != "$PhysicalNames") {
        }
        std::getline(in, line);
        for (int n = std::stoi(line); n > 0 && std::getline(in, line); --n) {
            const auto q = line.find('"');
            tags[line.substr(q)] = line.substr(0, q - 1);
        }
        return tags;
    };
    std::map<std::string, std::string> want = {{"\"White_matter_WM\"", "3 2"},
                                               {"\"CSF\"", "3 7"},
                                               {"\"boundary_White_matter_WM\"", "2 2"},
                                               {"\"boundary_CSF\"", "2 7"},
                                               {"\"interface_White_matter_WM_CSF\"", "2 200007"}};
    for (const auto format : {io::MeshFormat::Msh41, io::MeshFormat::Msh22}) {
        for (const core::TetMesh* m : {&all, static_cast<const core::TetMesh*>(&subset)}) {
            const std::string path = dir + "/" + io::export_file_name(format);
            io::write_mesh(*m, path, format, names);
            const auto got = physical(path);
            for (const auto& [name, tag] : want) {
                INFO(path << (m == &all ? " labels 1 2 7 " : " labels 2 7 ") << name);
                REQUIRE(got.count(name));
                CHECK(got.at(name) == tag);
            }
            if (m == &all) CHECK(got.at("\"interface_Grey_matter_White_matter_WM\"") == "2 100002");
        }
    }
    // VTU: region = label in the cell array; the surface tags in field data.
    io::write_mesh(subset, dir + "/subset.vtu", io::MeshFormat::Vtu, names);
    io::MeshReadInfo info;
    io::read_mesh(dir + "/subset.vtu", nullptr, &info);
    CHECK_THAT(info.fields["surface_tags"],
               Catch::Contains("200007 interface_White_matter_WM_CSF\n"));
    CHECK(io::surface_tag(7, 2) == 200007);
    CHECK(io::surface_tag(0, 7) == 7);
    CHECK(io::surface_tag(io::kMaxInterfaceLabel, io::kTagBase - 1) <= 2147483647);
    // Beyond the documented range the numeric formats refuse, naming the labels.
    core::TetMesh big = all;
    for (auto& r : big.region)
        if (r == 7) r = 30000;
    for (auto& r : big.region_in)
        if (r == 7) r = 30000;
    for (auto& r : big.region_out)
        if (r == 7) r = 30000;
    CHECK_NOTHROW(io::write_mesh(big, dir + "/big.msh", io::MeshFormat::Msh41, {}));
    for (auto& r : big.region)
        if (r == 2) r = 25000;
    for (auto& r : big.region_in)
        if (r == 2) r = 25000;
    for (auto& r : big.region_out)
        if (r == 2) r = 25000;
    CHECK_THROWS_WITH(io::write_mesh(big, dir + "/big.msh", io::MeshFormat::Msh41, {}),
                      Catch::Contains("labels 25000 and 30000"));
    CHECK_NOTHROW(io::write_mesh(big, dir + "/big.inp", io::MeshFormat::Abaqus, {}));
}

TEST_CASE("surface names fit Abaqus's 80 and Gmsh's 128 characters", "[io][export]") {
    // Region names take up to 64 characters; an interface name of two would take up to 139,
    // which gmsh cuts at 128 and Abaqus rejects: a surface name over 74 characters (80 with
    // "_NODES") is made of label numbers instead.
    const core::TetMesh mesh = three_region_cube();
    io::LabelTable names;
    names.set(1, std::string(60, 'A'));
    names.set(2, std::string(64, 'B'));
    names.set(7, "CSF");
    const std::string dir = fixtures::temp_dir("export_long_names");
    for (const auto format :
         {io::MeshFormat::Msh41, io::MeshFormat::Abaqus, io::MeshFormat::Febio}) {
        const std::string path = dir + "/" + io::export_file_name(format);
        io::write_mesh(mesh, path, format, names);
        const std::string text = [&] {
            std::ifstream in(path);
            std::ostringstream s;
            s << in.rdbuf();
            return s.str();
        }();
        INFO(path);
        CHECK_THAT(text, Catch::Contains("interface_1_2"));  // 135 characters with names
        CHECK_THAT(text, Catch::Contains("interface_2_7"));  // 78
        CHECK_THAT(text, Catch::Contains("interface_" + std::string(60, 'A') + "_CSF"));  // 74
        if (format == io::MeshFormat::Abaqus) {
            CHECK_THAT(text, Catch::Contains("NAME=interface_2_1\n"));
            CHECK_THAT(text, Catch::Contains("NAME=interface_7_2\n"));
            CHECK_THAT(text, Catch::Contains("NAME=interface_CSF_" + std::string(60, 'A') + "\n"));
        }
        std::istringstream lines(text);
        for (std::string line; std::getline(lines, line);) {
            if (format == io::MeshFormat::Abaqus && line.rfind("*", 0) == 0 &&
                line.rfind("**", 0) != 0 && line.find('=') != std::string::npos) {
                INFO(line);
                CHECK(line.size() - line.rfind('=') - 1 <= 80);
            }
        }
    }
}
