// `frontmesh check` and `frontmesh convert`: agreement with the referee meshcheck.py on
// validity and on the count of tets with skewness > 0.8; exit codes.

#include <algorithm>
#include <filesystem>
#include <map>
#include <random>
#include <regex>
#include <string>

#include <catch2/catch.hpp>

#include "io/export.h"
#include "io/label_table.h"
#include "io/mesh_io.h"
#include "pipeline/check.h"
#include "pipeline/core/quality.h"
#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/referee.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
namespace fs = std::filesystem;

namespace {

const std::string kMeshcheck = fixtures::meshcheck_path();

bool have_referee() {
    return !kMeshcheck.empty() &&
           std::system("/usr/bin/python3 -c 'import numpy, meshio, vtkmodules' > /dev/null 2>&1") ==
               0;
}

/// The referee's verdict: exit code and its JSON figures "valid", "n_tets", skewness
/// frac_gt_0_8 (times n_tets = the count).
struct Referee {
    int exit_code = -1;
    bool valid = false;
    long tets = 0;
    long skew_over_08 = 0;
};

Referee referee(const std::string& mesh, const std::string& dir, const std::string& extra = "") {
    const std::string json = dir + "/referee.json";
    fs::remove(json);
    const std::string cmd = "/usr/bin/python3 " + kMeshcheck + " '" + mesh + "' " + extra +
                            " --json '" + json + "' > '" + dir + "/referee.txt' 2>&1";
    const int status = std::system(cmd.c_str());
    Referee r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    const std::string text = frontmesh::testing::slurp(json);
    std::smatch m;
    if (std::regex_search(text, m, std::regex("\"valid\": (true|false)"))) r.valid = m[1] == "true";
    if (std::regex_search(text, m, std::regex("\"n_tets\": (\\d+)"))) r.tets = std::stol(m[1]);
    if (std::regex_search(text, m, std::regex("\"frac_gt_0_8\": ([0-9.eE+-]+)")))
        r.skew_over_08 = std::lround(std::stod(m[1]) * double(r.tets));
    return r;
}

long json_count(const std::string& json, const std::string& key) {
    std::smatch m;
    REQUIRE(std::regex_search(json, m, std::regex("\"" + key + "\": (\\d+)")));
    return std::stol(m[1]);
}

/// A 4^3-cell cube of two regions whose interior nodes are moved at random (fixed seed) by up
/// to `amplitude` of a cell: tets of many shapes, some with skewness > 0.8.
core::TetMesh jittered_cube(double amplitude, unsigned seed) {
    core::TetMesh mesh = fixtures::cube_tet_mesh(4, 1.0, true);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> d(-amplitude, amplitude);
    for (std::size_t v = static_cast<std::size_t>(mesh.surface_vertices); v < mesh.node_count();
         ++v)
        for (int k = 0; k < 3; ++k) mesh.xyz[3 * v + static_cast<std::size_t>(k)] += d(rng);
    return mesh;
}

/// Two unit cubes (6 tets each) sharing only the edge x = y = 1: a non-manifold boundary.
core::TetMesh cubes_sharing_an_edge() {
    core::TetMesh a = fixtures::cube_tet_mesh(1, 1.0);
    core::TetMesh mesh = a;
    std::map<std::array<double, 3>, std::int32_t> index;
    for (std::size_t v = 0; v < a.node_count(); ++v)
        index[{a.xyz[3 * v], a.xyz[3 * v + 1], a.xyz[3 * v + 2]}] = static_cast<std::int32_t>(v);
    std::vector<std::int32_t> map(a.node_count());
    for (std::size_t v = 0; v < a.node_count(); ++v) {
        const std::array<double, 3> p{a.xyz[3 * v] + 1.0, a.xyz[3 * v + 1] + 1.0, a.xyz[3 * v + 2]};
        const auto it = index.find(p);
        map[v] = it != index.end() ? it->second : mesh.add_node({p[0], p[1], p[2]});
    }
    for (const auto& t : a.tets)
        mesh.add_tet(map[static_cast<std::size_t>(t[0])], map[static_cast<std::size_t>(t[1])],
                     map[static_cast<std::size_t>(t[2])], map[static_cast<std::size_t>(t[3])], 1);
    core::derive_boundary_faces(mesh);
    mesh.surface_vertices = static_cast<std::int32_t>(mesh.node_count());
    return mesh;
}

}  // namespace

TEST_CASE("check_mesh: a valid two-region cube", "[pipeline][check]") {
    const core::TetMesh mesh = fixtures::cube_tet_mesh(3, 1.0, true);
    const pipeline::MeshReport r = pipeline::check_mesh(mesh);
    CHECK(r.valid());
    CHECK(r.referee.valid());
    CHECK(r.referee.closed_manifold());
    CHECK(r.referee.boundary_faces == 6 * 9 * 2);
    CHECK(r.referee.interface_faces == 9 * 2);
    CHECK(r.referee.volume == Approx(27.0));
    CHECK(r.referee.volume_rel_diff < 1e-12);
    CHECK(r.check.quality.tets == mesh.tet_count());
    CHECK_THAT(r.text(), Catch::Contains("RESULT    VALID"));
    CHECK_THAT(r.json(), Catch::Contains("\"valid\": true"));
}

TEST_CASE("check_mesh: invalid meshes are found", "[pipeline][check]") {
    SECTION("an inverted tet") {
        core::TetMesh mesh = fixtures::cube_tet_mesh(2, 1.0);
        std::swap(mesh.tets[5][0], mesh.tets[5][1]);
        const auto r = pipeline::check_mesh(mesh);
        CHECK(r.referee.inverted_tets == 1);
        CHECK(r.check.inverted_tets == 1);
        CHECK_FALSE(r.valid());
    }
    SECTION("a non-manifold boundary") {
        const auto r = pipeline::check_mesh(cubes_sharing_an_edge());
        CHECK(r.referee.nonmanifold_edges == 1);
        CHECK_FALSE(r.referee.closed_manifold());
        CHECK_FALSE(r.valid());
    }
    SECTION("a duplicated tet") {
        core::TetMesh mesh = fixtures::cube_tet_mesh(2, 1.0);
        mesh.tets.push_back(mesh.tets[3]);
        mesh.region.push_back(1);
        const auto r = pipeline::check_mesh(mesh);
        CHECK(r.referee.duplicate_tets == 1);
        CHECK(r.referee.nonconforming_faces > 0);
        CHECK_FALSE(r.valid());
    }
    SECTION("a reference surface that is not preserved") {
        const core::TetMesh mesh = fixtures::cube_tet_mesh(2, 1.0);
        core::SurfaceNetwork ref = core::boundary_surface(mesh);
        CHECK(pipeline::check_mesh(mesh, &ref).preservation->preserved());
        ref.xyz[0] += 0.01;  // one vertex moved: its triangles are no longer mesh faces
        const auto r = pipeline::check_mesh(mesh, &ref);
        REQUIRE(r.preservation);
        CHECK(r.preservation->ref_vertices_matched == r.preservation->ref_vertices - 1);
        CHECK_FALSE(r.preservation->preserved());
        CHECK_FALSE(r.valid());
        CHECK(r.referee.valid());
    }
}

TEST_CASE("frontmesh check agrees with meshcheck.py", "[pipeline][asan-slow][check][referee]") {
    if (!have_referee()) {
        WARN("meshcheck.py or Debian's python3-numpy/-meshio/-vtk9 missing: skipped");
        return;
    }
    const std::string dir = fixtures::temp_dir("check_referee");
    struct Case {
        std::string file;
        core::TetMesh mesh;
        io::MeshFormat format;
        bool valid;
    };
    core::TetMesh inverted = jittered_cube(0.2, 7);
    std::swap(inverted.tets[40][0], inverted.tets[40][1]);
    std::vector<Case> cases{{"jitter.vtu", jittered_cube(0.3, 1), io::MeshFormat::Vtu, true},
                            {"jitter.msh", jittered_cube(0.3, 2), io::MeshFormat::Msh41, true},
                            {"jitter.mesh", jittered_cube(0.3, 3), io::MeshFormat::Medit, true},
                            {"inverted.msh", inverted, io::MeshFormat::Msh22, false},
                            {"edge.mesh", cubes_sharing_an_edge(), io::MeshFormat::Medit, false}};
    long skewed_total = 0;
    for (const auto& c : cases) {
        INFO(c.file);
        const std::string path = dir + "/" + c.file;
        io::write_mesh(c.mesh, path, c.format, {});
        const Referee ref = referee(path, dir);
        const auto ours = run_frontmesh("check '" + path + "' --json", dir);
        INFO(ours.out << ours.err << frontmesh::testing::slurp(dir + "/referee.txt"));
        CHECK(ref.valid == c.valid);
        CHECK(ref.exit_code == (c.valid ? 0 : 1));
        CHECK(ours.exit_code == ref.exit_code);
        CHECK_THAT(ours.out,
                   Catch::Contains(std::string("\"valid\": ") + (ref.valid ? "true" : "false")));
        CHECK(json_count(ours.out, "n_tets") == ref.tets);
        CHECK(json_count(ours.out, "skewness_over_0_8") == ref.skew_over_08);
        skewed_total += ref.skew_over_08;
    }
    CHECK(skewed_total > 0);  // the comparison above saw skewed tets

    // --surface: preserved (exit 0) and not (exit 1), as meshcheck.py --strict-surface.
    const core::TetMesh mesh = fixtures::cube_tet_mesh(3, 1.0, true);
    io::write_mesh(mesh, dir + "/cube.vtu", io::MeshFormat::Vtu, {});
    core::SurfaceNetwork surface = core::boundary_surface(mesh);
    io::write_surface_vtu(surface, dir + "/surface.vtu", {});
    surface.xyz[3 * 5 + 2] += 0.05;
    io::write_surface_vtu(surface, dir + "/moved.vtu", {});
    for (const std::string ref_file : {"surface.vtu", "moved.vtu"}) {
        INFO(ref_file);
        const Referee ref = referee(dir + "/cube.vtu", dir,
                                    "--surface '" + dir + "/" + ref_file + "' --strict-surface");
        const auto ours = run_frontmesh("check cube.vtu --surface " + ref_file, dir);
        INFO(ours.out << ours.err);
        CHECK(ref.exit_code == (ref_file == "surface.vtu" ? 0 : 1));
        CHECK(ours.exit_code == ref.exit_code);
    }
}

TEST_CASE("frontmesh check and convert on the command line", "[pipeline][check]") {
    const std::string dir = fixtures::temp_dir("check_cli");
    const core::TetMesh mesh = fixtures::cube_tet_mesh(3, 1.0, true);
    io::write_mesh(mesh, dir + "/in.vtu", io::MeshFormat::Vtu, {});
    frontmesh::testing::write_file(dir + "/names.txt", "1 Grey matter\n2 White-matter\n");

    auto r = run_frontmesh("check in.vtu", dir);
    CHECK(r.exit_code == 0);
    CHECK_THAT(r.out, Catch::Contains("RESULT    VALID"));
    CHECK_THAT(r.out, Catch::Contains("skewness  (Eq. 1)"));

    r = run_frontmesh("convert in.vtu out.msh --labels names.txt", dir);
    INFO(r.out << r.err);
    CHECK(r.exit_code == 0);
    r = run_frontmesh("convert out.msh out22.msh --format msh22", dir);
    CHECK(r.exit_code == 0);
    r = run_frontmesh("convert out22.msh out.inp", dir);
    CHECK(r.exit_code == 0);
    r = run_frontmesh("convert out.inp out.feb", dir);
    CHECK(r.exit_code == 0);
    for (const char* f : {"out.msh", "out22.msh", "out.inp"}) {
        INFO(f);
        io::LabelTable names;
        const core::TetMesh back = io::read_mesh(dir + "/" + f, &names);
        CHECK(back.xyz == mesh.xyz);
        CHECK(back.tets == mesh.tets);
        CHECK(back.region == mesh.region);
        CHECK(names.name(1) == "Grey_matter");
        CHECK(names.name(2) == "White_matter");
        r = run_frontmesh(std::string("check ") + f, dir);
        CHECK(r.exit_code == 0);
    }
    CHECK_THAT(frontmesh::testing::slurp(dir + "/out.feb"),
               Catch::Contains("<SolidDomain name=\"White_matter\""));

    // Bad input: exit 2 with one line naming the file.
    {
        // Damaged compressed data: VTK's zlib compressor printed two coloured log lines of
        // its own before ours (the malformed-input campaign, issue 21).
        std::string bytes = frontmesh::testing::slurp(dir + "/in.vtu");
        const std::size_t data = bytes.find('_', bytes.find("<AppendedData"));
        REQUIRE(data != std::string::npos);
        const std::size_t last = bytes.find("</AppendedData>");
        for (std::size_t i = data + 60; i < std::min(data + 400, last - 20); i += 7)
            bytes[i] ^= 0x5a;
        frontmesh::testing::write_file(dir + "/damaged.vtu", bytes);
        r = run_frontmesh("check damaged.vtu", dir);
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK_THAT(r.err,
                   Catch::StartsWith("frontmesh: error: ") && Catch::Contains("damaged.vtu"));
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    }
    {
        // A region that is no positive label: an internal check of the FEBio writer, exit 1
        // (campaign seed 7, issue 21); convert refuses it.
        core::TetMesh negative = mesh;
        for (auto& region : negative.region) region = -region;
        io::write_mesh(negative, dir + "/negative.vtu", io::MeshFormat::Vtu, {});
        r = run_frontmesh("convert negative.vtu negative.feb", dir);
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK_THAT(r.err, Catch::Contains("negative.vtu': tet 0 has region -"));
        CHECK_FALSE(fs::exists(fs::path(dir) / "negative.feb"));
    }
    r = run_frontmesh("check missing.msh", dir);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains("missing.msh"));
    frontmesh::testing::write_file(
        dir + "/bad.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n2\n0 0 0 0\n1 1\n");
    r = run_frontmesh("check bad.mesh", dir);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains("bad.mesh:6"));
    r = run_frontmesh("convert in.vtu out.stl", dir);
    CHECK(r.exit_code == 2);
    r = run_frontmesh("convert in.vtu out.msh --format nope", dir);
    CHECK(r.exit_code == 2);
    r = run_frontmesh("check in.vtu --set a.b=1", dir);
    CHECK(r.exit_code == 2);

    // An invalid mesh: exit 1.
    core::TetMesh inverted = mesh;
    std::swap(inverted.tets[0][0], inverted.tets[0][1]);
    io::write_mesh(inverted, dir + "/inverted.msh", io::MeshFormat::Msh41, {});
    r = run_frontmesh("check inverted.msh --json", dir);
    CHECK(r.exit_code == 1);
    CHECK_THAT(r.out, Catch::Contains("\"valid\": false"));
    CHECK_THAT(r.out, Catch::Contains("\"inverted_tets\": 1"));
}
