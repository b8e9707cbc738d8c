// The volume stages through the command line: tetra and refine after the surface stages,
// a surface meshed as it is (--from tetra), every mesh refereed by meshcheck.py.

#include <algorithm>
#include <filesystem>

#include <catch2/catch.hpp>

#include "io/mesh_io.h"
#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/referee.h"
#include "tests/pipeline/cli_helpers.h"
#include "volume/mesh_check.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
using frontmesh::testing::slurp;
using frontmesh::testing::write_file;
namespace fs = std::filesystem;

namespace {

const std::string kReferee = fixtures::meshcheck_path();

// meshcheck.py MESH --surface SURFACE --strict-surface: exit status and its report.
std::pair<int, std::string> referee(const fs::path& mesh, const fs::path& surface,
                                    const fs::path& dir) {
    const fs::path report = dir / "meshcheck.txt";
    const std::string cmd = "/usr/bin/python3 '" + kReferee + "' '" + mesh.string() +
                            "' --surface '" + surface.string() + "' --strict-surface --json '" +
                            (dir / "meshcheck.json").string() + "' > '" + report.string() +
                            "' 2>&1";
    const int status = std::system(cmd.c_str());
    return {WEXITSTATUS(status), slurp(report)};
}

}  // namespace

TEST_CASE("nested phantom: image to refined tet mesh, three regions, surface kept",
          "[pipeline][asan-slow][volume]") {
    const std::string dir = fixtures::temp_dir("run_volume_phantom");
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.6), dir + "/phantom.mha");
    write_file(dir + "/recipe.yaml",
               "input:\n  image: phantom.mha\noutput:\n  dir: out\n  formats: [vtu, msh]\n");
    const auto r = run_frontmesh("run recipe.yaml --quiet", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const fs::path out = fs::path(dir) / "out";
    for (const char* f : {"checkpoints/04-tetra.vtu", "checkpoints/05-refine.vtu", "mesh.vtu",
                          "run-surface.pvd", "run-volume.pvd"})
        CHECK(fs::exists(out / f));
    // Stepping through a collection never mixes triangles and tets (issue 22).
    const std::string surfaces = slurp(out / "run-surface.pvd");
    const std::string volumes = slurp(out / "run-volume.pvd");
    CHECK_THAT(surfaces, Catch::Contains("checkpoints/01-extract.vtu") &&
                             Catch::Contains("checkpoints/03-remesh.vtu") &&
                             !Catch::Contains("04-tetra") && !Catch::Contains("05-refine"));
    CHECK_THAT(volumes, Catch::Contains("timestep=\"0\"") &&
                            Catch::Contains("checkpoints/04-tetra.vtu") &&
                            Catch::Contains("checkpoints/05-refine.vtu") &&
                            !Catch::Contains("extract") && !Catch::Contains("remesh"));

    // Our own checks: valid, every region's volume equal to what its boundary encloses.
    const core::TetMesh tetra = io::read_tet_mesh((out / "checkpoints/04-tetra.vtu").string());
    const core::TetMesh mesh = io::read_tet_mesh((out / "mesh.vtu").string());
    const volume::TetMeshCheck before = volume::check_tet_mesh(tetra);
    const volume::TetMeshCheck after = volume::check_tet_mesh(mesh);
    INFO(before.summary() << "\n" << after.summary());
    CHECK(before.valid());
    CHECK(after.valid());
    REQUIRE(after.region_volume.size() == 3);
    for (const auto& [label, v] : after.region_volume)
        CHECK(v == Approx(after.region_enclosed_volume.at(label)).epsilon(1e-9));
    // Refinement lowers the mean skewness, in every region.
    CHECK(after.quality.mean_skewness < before.quality.mean_skewness);
    for (const auto& [label, q] : after.region_quality)
        CHECK(q.mean_skewness < before.region_quality.at(label).mean_skewness);

    // The outside referee: valid, and the remeshed surface is kept exactly.
    if (fs::exists(kReferee)) {
        const auto [status, report] =
            referee(out / "mesh.vtu", out / "checkpoints/03-remesh.vtu", dir);
        INFO(report);
        CHECK(status == 0);
    } else {
        WARN("meshcheck.py not found beside the repository; referee skipped");
    }
    // Other tools read the result: meshio sees the same nodes, tets and regions.
    const std::string py =
        "/usr/bin/python3 -c \"import meshio, sys; m = meshio.read(sys.argv[1]); "
        "print(len(m.points), len(m.cells_dict['tetra']), "
        "sorted(set(int(r) for r in m.cell_data['region'][0])))\" '" +
        (out / "mesh.vtu").string() + "' > '" + dir + "/meshio.txt' 2>&1";
    CHECK(std::system(py.c_str()) == 0);
    CHECK_THAT(slurp(fs::path(dir) / "meshio.txt"),
               Catch::Contains(std::to_string(mesh.node_count()) + " " +
                               std::to_string(mesh.tet_count()) + " [1, 2, 3]\n"));

    const std::string summary = slurp(out / "summary.json");
    CHECK_THAT(summary, Catch::Contains("\"name\": \"tetra\"") &&
                            Catch::Contains("\"name\": \"refine\"") &&
                            Catch::Contains("\"valid\": true") && Catch::Contains("refine.pass1."));

    for (const char* f : {"mesh.msh", "report.html", "tet_skewness.svg"})
        CHECK(fs::exists(out / f));

    // An unchanged re-run does no work: no stage runs, no result file is written again.
    const auto mesh_time = fs::last_write_time(out / "mesh.vtu");
    const auto msh_time = fs::last_write_time(out / "mesh.msh");
    const auto report_time = fs::last_write_time(out / "report.html");
    const auto again = run_frontmesh("run recipe.yaml", dir);
    CHECK(again.exit_code == 0);
    CHECK_THAT(again.err, Catch::Contains("up to date"));
    CHECK(fs::last_write_time(out / "mesh.vtu") == mesh_time);
    CHECK(fs::last_write_time(out / "mesh.msh") == msh_time);
    CHECK(fs::last_write_time(out / "report.html") == report_time);

    SECTION("--from refine reads the tetra checkpoint back") {
        const auto again = run_frontmesh("run recipe.yaml --from refine", dir);
        INFO(again.err);
        CHECK(again.exit_code == 0);
        CHECK_THAT(again.err,
                   Catch::Contains("reading checkpoint") && Catch::Contains("04-tetra.vtu"));
        CHECK(io::read_tet_mesh((out / "mesh.vtu").string()).tets == mesh.tets);  // deterministic
    }
}

TEST_CASE("a surface is meshed as it is with --from tetra", "[pipeline][volume]") {
    const std::string dir = fixtures::temp_dir("run_volume_surface");
    io::write_surface_vtu(fixtures::uv_sphere(10.0, 12), dir + "/sphere.vtu", {});
    write_file(dir + "/recipe.yaml",
               "input:\n  surface: sphere.vtu\noutput:\n  dir: out\ntetra:\n  stretching: 1.05\n");
    const auto r = run_frontmesh("run recipe.yaml --quiet --from tetra", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.err, !Catch::Contains("over 130 degrees"));  // none on this sphere
    const fs::path out = fs::path(dir) / "out";
    CHECK_FALSE(fs::exists(out / "checkpoints/02-repair.vtu"));
    const core::TetMesh mesh = io::read_tet_mesh((out / "mesh.vtu").string());
    CHECK(volume::check_tet_mesh(mesh).valid());
    CHECK(mesh.face_count() == fixtures::uv_sphere(10.0, 12).face_count());
    if (fs::exists(kReferee)) {
        const auto [status, report] = referee(out / "mesh.vtu", fs::path(dir) / "sphere.vtu", dir);
        INFO(report);
        CHECK(status == 0);
    }
    // --from refine refines the tetra checkpoint of the surface again.
    const auto again = run_frontmesh("run recipe.yaml --from refine", dir);
    INFO(again.err);
    CHECK(again.exit_code == 0);
    CHECK_THAT(again.err, Catch::Contains("reading checkpoint") && Catch::Contains("04-tetra.vtu"));
    CHECK(io::read_tet_mesh((out / "mesh.vtu").string()).tets == mesh.tets);  // deterministic
    // Without that checkpoint it is an error naming it, and nothing is written.
    fs::remove(out / "checkpoints/04-tetra.vtu");
    const auto before = fs::last_write_time(out / "mesh.vtu");
    const auto bad = run_frontmesh("run recipe.yaml --quiet --from refine", dir);
    CHECK(bad.exit_code == 2);
    CHECK_THAT(bad.err, Catch::Contains("04-tetra.vtu") && Catch::Contains("does not exist"));
    CHECK(fs::last_write_time(out / "mesh.vtu") == before);
}

TEST_CASE("given triangles over 130 degrees are named before tetra keeps them",
          "[pipeline][volume]") {
    // A box whose top has one vertex moved in its plane most of the way to the middle of an
    // opposite edge: a valid surface with obtuse triangles there.
    core::SurfaceNetwork box = fixtures::grid_box(6.0, 6.0, 6.0, 1.0);
    std::int32_t v = -1;
    for (std::size_t i = 0; i < box.vertex_count(); ++i)
        if ((box.point(std::int32_t(i)) - Eigen::Vector3d(3.0, 3.0, 6.0)).norm() < 1e-9)
            v = std::int32_t(i);
    REQUIRE(v >= 0);
    for (const auto& t : box.faces) {
        const auto at = std::find(t.begin(), t.end(), v);
        if (at == t.end()) continue;
        const auto k = std::size_t(at - t.begin());
        const Eigen::Vector3d mid = 0.5 * (box.point(t[(k + 1) % 3]) + box.point(t[(k + 2) % 3]));
        box.point(v) += 0.85 * (mid - box.point(v));
        break;
    }
    const std::string dir = fixtures::temp_dir("run_volume_obtuse");
    io::write_surface_vtu(box, dir + "/box.vtu", {});
    write_file(dir + "/recipe.yaml", "input:\n  surface: box.vtu\noutput:\n  dir: out\n");
    const auto r = run_frontmesh("run recipe.yaml --quiet --from tetra", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.err, Catch::Contains("warning: input.surface") && Catch::Contains("box.vtu") &&
                          Catch::Contains("triangles have an angle over 130 degrees") &&
                          Catch::Contains(" of 432 triangles") && Catch::Contains(", 6) mm"));
    CHECK(volume::check_tet_mesh(io::read_tet_mesh(dir + "/out/mesh.vtu")).valid());
    // Through remesh the surface is remeshed first: no such warning.
    const auto again = run_frontmesh("run recipe.yaml --quiet --from remesh", dir);
    INFO(again.err);
    CHECK(again.exit_code == 0);
    CHECK_THAT(again.err, !Catch::Contains("over 130 degrees"));
}

TEST_CASE("AAL left hippocampus: real image to refined tets, refereed, exported",
          "[pipeline][asan-slow][volume][e2e]") {
    const std::string dir = fixtures::temp_dir("run_volume_hippocampus");
    const std::string recipe = std::string(FRONTMESH_SOURCE_DIR) + "/examples/aal-hippocampus.yaml";
    const auto r =
        run_frontmesh("run '" + recipe + "' --quiet --set output.dir=" + dir + "/out", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const fs::path out = fs::path(dir) / "out";
    const core::TetMesh mesh = io::read_tet_mesh((out / "mesh.vtu").string());
    const volume::TetMeshCheck check = volume::check_tet_mesh(mesh);
    INFO(check.summary());
    CHECK(check.valid());
    CHECK(check.volume == Approx(check.enclosed_volume).epsilon(1e-9));
    CHECK(mesh.tet_count() > 10000);
    CHECK(check.quality.min_dihedral_deg > 10.0);
    CHECK(check.quality.skewness_over_08 <= mesh.tet_count() / 10000);  // at most 0.01%
    if (fs::exists(kReferee)) {
        const auto [status, report] =
            referee(out / "mesh.vtu", out / "checkpoints/03-remesh.vtu", dir);
        INFO(report);
        CHECK(status == 0);
    }
    // The region carries its atlas name (aal.nii.txt) into the exports; meshio reads them.
    CHECK_THAT(slurp(out / "mesh.inp"), Catch::Contains("Hippocampus_L"));
    CHECK_THAT(slurp(out / "mesh.msh"), Catch::Contains("Hippocampus_L"));
    const std::string py =
        "/usr/bin/python3 -c \"import meshio, sys; "
        "print(*[len(meshio.read(f).cells_dict['tetra']) for f in sys.argv[1:]])\" '" +
        (out / "mesh.vtu").string() + "' '" + (out / "mesh.msh").string() + "' '" +
        (out / "mesh.inp").string() + "' > '" + dir + "/meshio.txt' 2>/dev/null";
    CHECK(std::system(py.c_str()) == 0);
    const std::string n = std::to_string(mesh.tet_count());
    CHECK_THAT(slurp(fs::path(dir) / "meshio.txt"), Catch::Contains(n + " " + n + " " + n + "\n"));
}

TEST_CASE("a defective surface given to --from tetra is bad input, named, nothing written",
          "[pipeline][volume]") {
    const std::string dir = fixtures::temp_dir("run_volume_bad_surface");
    struct Case {
        const char* name;
        const char* words;
        void (*spoil)(core::SurfaceNetwork&);
    };
    const Case cases[] = {
        {"open", "open boundary of region 1",
         [](core::SurfaceNetwork& s) {
             s.faces.pop_back();
             s.region_in.pop_back();
             s.region_out.pop_back();
         }},
        {"flipped", "misoriented boundary of region 1",
         [](core::SurfaceNetwork& s) { std::swap(s.faces[5][0], s.faces[5][1]); }},
        {"inverted", "region 1 encloses -",
         [](core::SurfaceNetwork& s) {
             for (auto& f : s.faces) std::swap(f[0], f[1]);
         }},
        {"same_sides", "region_out is 1",
         [](core::SurfaceNetwork& s) { std::fill(s.region_out.begin(), s.region_out.end(), 1); }},
    };
    for (const Case& c : cases) {
        INFO(c.name);
        core::SurfaceNetwork s = fixtures::uv_sphere(10.0, 12);
        c.spoil(s);
        io::write_surface_vtu(s, dir + "/" + c.name + ".vtu", {});
        write_file(dir + "/" + c.name + ".yaml", std::string("input:\n  surface: ") + c.name +
                                                     ".vtu\noutput:\n  dir: out-" + c.name + "\n");
        const auto r =
            run_frontmesh(std::string("run ") + c.name + ".yaml --quiet --from tetra", dir);
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK_THAT(r.err, Catch::Contains(c.words) && Catch::Contains("mm") &&
                              Catch::Contains(std::string(c.name) + ".vtu"));
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
        CHECK_FALSE(fs::exists(fs::path(dir) / (std::string("out-") + c.name)));
    }
}
