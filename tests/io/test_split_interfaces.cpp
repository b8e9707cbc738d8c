// output.split_interfaces (issue 22): nodes doubled on chosen interfaces, per group of
// regions joined across unsplit faces, and the exports that carry the copies and the pairs.

#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "io/export.h"
#include "io/mesh_io.h"
#include "io/split_interfaces.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "tests/fixtures/phantoms.h"

using namespace frontmesh;

namespace {

/// A cube of 4^3 Kuhn cells (edge 2 mm) with regions by tet centre: `region_of(x, z)`;
/// faces derived, surface nodes first.
template <class RegionOf>
core::TetMesh cube(RegionOf region_of) {
    core::TetMesh mesh = fixtures::cube_tet_mesh(4, 0.5, false);
    for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
        Eigen::Vector3d c = Eigen::Vector3d::Zero();
        for (int k = 0; k < 4; ++k) c += mesh.point(mesh.tets[t][k]) / 4;
        mesh.region[t] = region_of(c.x(), c.z());
    }
    core::derive_boundary_faces(mesh);
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

/// Regions 1 (x < 1, z < 1), 2 (x < 1, z > 1), 7 (x > 1): interfaces 1|2, 1|7, 2|7 meeting
/// at the junction line x = 1, z = 1.
core::TetMesh three_regions() {
    return cube([](double x, double z) { return x > 1.0 ? 7 : (z < 1.0 ? 1 : 2); });
}

std::set<std::int32_t> region_nodes(const core::TetMesh& mesh, core::Label r) {
    std::set<std::int32_t> nodes;
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        if (mesh.region[t] == r) nodes.insert(mesh.tets[t].begin(), mesh.tets[t].end());
    return nodes;
}

std::vector<std::int32_t> shared(const std::set<std::int32_t>& a, const std::set<std::int32_t>& b) {
    std::vector<std::int32_t> s;
    std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(s));
    return s;
}

std::map<core::Label, double> region_volumes(const core::TetMesh& mesh) {
    std::map<core::Label, double> v;
    for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
        const auto& q = mesh.tets[t];
        v[mesh.region[t]] += core::tet_signed_volume(mesh.point(q[0]), mesh.point(q[1]),
                                                     mesh.point(q[2]), mesh.point(q[3]));
    }
    return v;
}

/// The split mesh's invariants: regions, tets and volumes as before, every tet positive,
/// copies at their node's coordinates, faces on surface nodes, twin faces paired.
void check_split(const core::TetMesh& before, const core::TetMesh& after) {
    REQUIRE(after.tet_count() == before.tet_count());
    CHECK(after.region == before.region);
    const auto va = region_volumes(before), vb = region_volumes(after);
    for (const auto& [r, v] : va) CHECK(vb.at(r) == Approx(v).epsilon(1e-12));
    for (std::size_t t = 0; t < after.tet_count(); ++t) {
        const auto& q = after.tets[t];
        CHECK(core::tet_signed_volume(after.point(q[0]), after.point(q[1]), after.point(q[2]),
                                      after.point(q[3])) > 0);
    }
    REQUIRE(after.twin.size() == after.node_count());
    REQUIRE(after.face_twin.size() == after.face_count());
    for (std::size_t v = 0; v < after.node_count(); ++v) {
        const std::int32_t w = after.twin[v];
        CHECK(after.twin[static_cast<std::size_t>(w)] == w);  // a copy of a kept node
        CHECK((after.point(static_cast<std::int32_t>(v)) - after.point(w)).norm() == 0.0);
    }
    for (std::size_t f = 0; f < after.face_count(); ++f) {
        for (std::int32_t v : after.faces[f]) CHECK(v < after.surface_vertices);
        const std::int32_t g = after.face_twin[f];
        if (g < 0) continue;
        const auto& a = after.faces[f];
        const auto& b = after.faces[static_cast<std::size_t>(g)];
        CHECK(after.face_twin[static_cast<std::size_t>(g)] == static_cast<std::int32_t>(f));
        CHECK(after.region_in[f] == after.region_out[static_cast<std::size_t>(g)]);
        // The same triangle, reversed: a0 a1 a2 = b0 b2 b1 in coordinates.
        CHECK((after.point(a[0]) - after.point(b[0])).norm() == 0.0);
        CHECK((after.point(a[1]) - after.point(b[2])).norm() == 0.0);
        CHECK((after.point(a[2]) - after.point(b[1])).norm() == 0.0);
    }
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

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

TEST_CASE("splitting one interface doubles its nodes but where it meets unsplit ones",
          "[io][split]") {
    const core::TetMesh mesh = three_regions();
    const core::TetMesh split = io::split_interfaces(mesh, {false, {{2, 1}}});
    check_split(mesh, split);
    CHECK(split.node_count() > mesh.node_count());
    // Regions 1 and 2 now share only the nodes of the junction line with 7 (x = 1, z = 1),
    // where they stay joined through region 7's unsplit interfaces.
    const auto common = shared(region_nodes(split, 1), region_nodes(split, 2));
    CHECK(!common.empty());
    const auto with_7 = region_nodes(split, 7);
    for (std::int32_t v : common) {
        INFO("node " << v);
        CHECK(with_7.count(v) == 1);
        CHECK(split.point(v).x() == Approx(1.0));
        CHECK(split.point(v).z() == Approx(1.0));
    }
    // 1|7 and 2|7 are not split: they still share their nodes.
    CHECK(shared(region_nodes(mesh, 1), region_nodes(mesh, 7)).size() ==
          shared(region_nodes(split, 1), region_nodes(split, 7)).size());
    // Each 1|2 face is there twice, once per side; the others once.
    std::size_t twins = 0;
    for (std::size_t f = 0; f < split.face_count(); ++f) {
        const bool is_12 = std::min(split.region_in[f], split.region_out[f]) == 1 &&
                           std::max(split.region_in[f], split.region_out[f]) == 2;
        CHECK((split.face_twin[f] >= 0) == is_12);
        twins += is_12;
    }
    std::size_t faces_12 = 0;
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        faces_12 += std::min(mesh.region_in[f], mesh.region_out[f]) == 1 &&
                    std::max(mesh.region_in[f], mesh.region_out[f]) == 2;
    CHECK(twins == 2 * faces_12);
    CHECK(split.face_count() == mesh.face_count() + faces_12);
}

TEST_CASE("splitting every interface leaves no node shared between regions", "[io][split]") {
    const core::TetMesh mesh = three_regions();
    const core::TetMesh split = io::split_interfaces(mesh, {true, {}});
    check_split(mesh, split);
    const auto n1 = region_nodes(split, 1), n2 = region_nodes(split, 2),
               n7 = region_nodes(split, 7);
    CHECK(shared(n1, n2).empty());
    CHECK(shared(n1, n7).empty());
    CHECK(shared(n2, n7).empty());
    // A node of the junction line has three copies (the kept one and two more).
    std::map<std::int32_t, int> copies;
    for (std::int32_t w : split.twin) ++copies[w];
    int most = 0;
    for (const auto& [w, c] : copies) most = std::max(most, c);
    CHECK(most == 3);
    // Split again from the VTU: the twins travel with the file.
    const std::string dir = fixtures::temp_dir("split_vtu");
    io::write_tet_mesh_vtu(split, dir + "/mesh.vtu", {});
    const core::TetMesh back = io::read_tet_mesh(dir + "/mesh.vtu");
    CHECK(back.twin == split.twin);
    CHECK(back.face_twin == split.face_twin);
    CHECK(back.faces == split.faces);
}

TEST_CASE("no split leaves the mesh as it is", "[io][split]") {
    const core::TetMesh mesh = three_regions();
    const core::TetMesh same = io::split_interfaces(mesh, {});
    CHECK(same.xyz == mesh.xyz);
    CHECK(same.tets == mesh.tets);
    CHECK(same.faces == mesh.faces);
    INFO("mesh twin " << mesh.twin.size() << " same twin " << same.twin.size());
    CHECK(same.twin.empty());
    CHECK(io::split_interfaces_text({}) == "none");
    CHECK(io::split_interfaces_text({true, {}}) == "all");
    CHECK(io::split_interfaces_text({false, {{1, 2}, {2, 7}}}) == "[[1, 2], [2, 7]]");
}

TEST_CASE("split_interfaces refuses labels that are no regions or do not touch", "[io][split]") {
    // Slabs along x: 1 | 2 | 3; 1 and 3 do not touch.
    const core::TetMesh slabs =
        cube([](double x, double) { return x < 0.5 ? 1 : (x < 1.5 ? 2 : 3); });
    CHECK_THROWS_MATCHES(
        io::split_interfaces(slabs, {false, {{1, 3}}}), core::InputError,
        Catch::Matchers::Message("output.split_interfaces: [1, 3]: regions 1 and 3 do not touch "
                                 "(no interface between them)"));
    CHECK_THROWS_MATCHES(
        io::split_interfaces(slabs, {false, {{1, 9}}}), core::InputError,
        Catch::Matchers::Message(
            "output.split_interfaces: [1, 9]: label 9 is not a region of the mesh"));
    CHECK_THROWS_AS(io::split_interfaces(slabs, {false, {{2, 2}}}), core::InputError);
    const core::TetMesh split = io::split_interfaces(slabs, {false, {{1, 2}, {3, 2}}});
    check_split(slabs, split);
    CHECK(shared(region_nodes(split, 1), region_nodes(split, 2)).empty());
    CHECK(shared(region_nodes(split, 2), region_nodes(split, 3)).empty());
}

TEST_CASE("exports of a split mesh carry the copies and both sides as a pair",
          "[io][split][export]") {
    const core::TetMesh split = io::split_interfaces(three_regions(), {false, {{1, 2}}});
    const std::string dir = fixtures::temp_dir("split_exports");
    io::LabelTable names;
    names.set(1, "Low");
    names.set(2, "High");
    names.set(7, "Side");

    // Abaqus: both sides as element surfaces and the commented *TIE / *CONTACT PAIR.
    io::write_mesh(split, dir + "/mesh.inp", io::MeshFormat::Abaqus, names);
    const std::string inp = slurp(dir + "/mesh.inp");
    CHECK_THAT(inp, Catch::Contains("*SURFACE, TYPE=ELEMENT, NAME=interface_Low_High\n"));
    CHECK_THAT(inp, Catch::Contains("*SURFACE, TYPE=ELEMENT, NAME=interface_High_Low\n"));
    CHECK_THAT(inp, Catch::Contains("** split 100002 labels 1 2\n*NSET, "
                                    "NSET=interface_High_Low_SLAVE_NODES\n"));
    CHECK_THAT(inp, Catch::Contains("*SURFACE, TYPE=NODE, NAME=interface_High_Low_SLAVE\n"
                                    "interface_High_Low_SLAVE_NODES\n***TIE, NAME=T100002, "
                                    "ADJUST=NO\n**interface_High_Low_SLAVE, "
                                    "interface_Low_High\n"));
    CHECK_THAT(inp, !Catch::Contains("T100007"));  // 1|7 is not split
    // Read back: the same nodes, tets and regions.
    const core::TetMesh back = io::read_mesh(dir + "/mesh.inp");
    CHECK(back.node_count() == split.node_count());
    CHECK(back.tet_count() == split.tet_count());

    // FEBio: each side only its own faces (check_feb.py: outward faces of elements).
    io::write_mesh(split, dir + "/mesh.feb", io::MeshFormat::Febio, names);
    const Run feb = run("/usr/bin/python3 '" FRONTMESH_SOURCE_DIR "/tests/io/check_feb.py' '" +
                        dir + "/mesh.feb'");
    INFO(feb.out);
    CHECK(feb.exit_code == 0);
    CHECK_THAT(feb.out, Catch::Contains("count pairs 3\n"));
    CHECK_THAT(feb.out, Catch::Contains("split pairs 1\n"));

    // Gmsh: the copies are nodes of their own, and the view "twin".
    for (const bool binary : {false, true}) {
        io::write_mesh(split, dir + "/mesh.msh", io::MeshFormat::Msh41, names, {}, {binary});
        const std::string msh = slurp(dir + "/mesh.msh");
        CHECK_THAT(msh, Catch::Contains("$NodeData\n1\n\"twin\"\n"));
        const core::TetMesh m = io::read_mesh(dir + "/mesh.msh");
        CHECK(m.node_count() == split.node_count());
        // gmsh reads it, view included (`gmsh -check` would call the twin triangles
        // duplicates: it merges coincident nodes first).
        const Run gmsh = run("gmsh '" + dir + "/mesh.msh' -0 -v 99 -o '" + dir + "/again.msh'");
        INFO(gmsh.out);
        CHECK(gmsh.exit_code == 0);
        CHECK_THAT(gmsh.out,
                   Catch::Contains("Reading view `twin' step 0") && !Catch::Contains("Error"));
    }
    const Run meshio =
        run("/usr/bin/python3 -c \"import meshio; m = meshio.read('" + dir +
            "/mesh.msh'); t = m.point_data['twin']; print('twins', int((t != range(1, len(t) + "
            "1)).sum()))\"");
    INFO(meshio.out);
    CHECK(meshio.exit_code == 0);
    std::size_t copies = 0;
    for (std::size_t v = 0; v < split.node_count(); ++v)
        copies += split.twin[v] != static_cast<std::int32_t>(v);
    CHECK_THAT(meshio.out, Catch::Contains("twins " + std::to_string(copies)));
}
