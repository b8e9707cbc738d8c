#include <filesystem>
#include <regex>

#include <catch2/catch.hpp>

#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/referee.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
using frontmesh::testing::slurp;
using frontmesh::testing::write_file;
namespace fs = std::filesystem;

namespace {

std::size_t temp_files_below(const fs::path& dir) {
    std::size_t n = 0;
    if (fs::exists(dir))
        for (const auto& e : fs::recursive_directory_iterator(dir))
            n += e.path().filename().string().find(".tmp-") != std::string::npos;
    return n;
}

// A folder with the nested-ellipsoid phantom as a MetaImage and a recipe for it.
std::string phantom_run_dir(const std::string& name) {
    const std::string dir = fixtures::temp_dir(name);
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.7), dir + "/phantom.mha");
    write_file(dir + "/recipe.yaml", "input:\n  image: phantom.mha\noutput:\n  dir: out\n");
    return dir;
}

}  // namespace

TEST_CASE("run writes checkpoints, run.pvd, summary, log and result", "[pipeline][asan-slow]") {
    const std::string dir = phantom_run_dir("run_outputs");
    const auto r = run_frontmesh("run recipe.yaml --quiet --until repair", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const fs::path out = fs::path(dir) / "out";
    for (const char* f :
         {"checkpoints/01-extract.vtu", "checkpoints/02-repair.vtu", "checkpoints/01-extract.hash",
          "run-surface.pvd", "summary.json", "frontmesh.log", "surface.vtu"})
        CHECK(fs::exists(out / f));
    CHECK(temp_files_below(out) == 0);
    const std::string summary = slurp(out / "summary.json");
    CHECK_THAT(summary,
               Catch::Contains("\"status\": \"ok\"") && Catch::Contains("\"name\": \"repair\"") &&
                   Catch::Contains("\"regions_closed\": 3") && Catch::Contains("\"peak_rss_mb\"") &&
                   Catch::Contains("\"frame\": \"lps\""));
    // The outside referee, region by region (the network itself is non-manifold at junctions).
    const std::string referee = fixtures::meshcheck_path();
    if (!referee.empty()) {
        const std::string cmd = "/usr/bin/python3 '" + std::string(FRONTMESH_SOURCE_DIR) +
                                "/scripts/meshcheck_regions.py' '" +
                                (out / "checkpoints/02-repair.vtu").string() + "' '" + dir +
                                "/regions' '" + referee + "' > '" + dir + "/referee.txt' 2>&1";
        const int status = std::system(cmd.c_str());
        INFO(slurp(dir + "/referee.txt"));
        CHECK(WEXITSTATUS(status) == 0);
        CHECK_THAT(slurp(dir + "/referee.txt"),
                   Catch::Contains("3 regions checked with meshcheck.py, 0 invalid"));
    } else {
        WARN("meshcheck.py not found beside the repository; referee skipped");
    }
    // One collection per kind: this run made surfaces only (issue 22).
    const std::string pvd = slurp(out / "run-surface.pvd");
    CHECK_THAT(pvd, Catch::Contains("checkpoints/01-extract.vtu") &&
                        Catch::Contains("checkpoints/02-repair.vtu"));
    CHECK(!fs::exists(out / "run-volume.pvd"));
    CHECK(!fs::exists(out / "run.pvd"));
    CHECK_THAT(r.out, Catch::Contains("run-surface.pvd"));

    SECTION("an unchanged re-run skips every stage") {
        const auto before = fs::last_write_time(out / "checkpoints/02-repair.vtu");
        const auto again = run_frontmesh("run recipe.yaml --until repair", dir);
        REQUIRE(again.exit_code == 0);
        CHECK_THAT(again.err, Catch::Contains("up to date"));
        CHECK(fs::last_write_time(out / "checkpoints/02-repair.vtu") == before);
        CHECK_THAT(slurp(out / "summary.json"), Catch::Contains("\"status\": \"skipped\""));
    }
    SECTION("a changed repair key re-runs repair only") {
        const auto extract_time = fs::last_write_time(out / "checkpoints/01-extract.vtu");
        const auto again =
            run_frontmesh("run recipe.yaml --until repair --set repair.max_hole_edges=50", dir);
        REQUIRE(again.exit_code == 0);
        CHECK(fs::last_write_time(out / "checkpoints/01-extract.vtu") == extract_time);
        CHECK_THAT(again.err, Catch::Contains("[2/2] repair") && !Catch::Contains("] extract"));
    }
    SECTION("--from and --until") {
        const auto from = run_frontmesh("run recipe.yaml --from repair --until repair", dir);
        CHECK(from.exit_code == 0);
        CHECK_THAT(from.err,
                   Catch::Contains("reading checkpoint") && Catch::Contains("[2/2] repair"));
        const auto until = run_frontmesh("run recipe.yaml --force --until extract", dir);
        CHECK(until.exit_code == 0);
        CHECK_THAT(until.err, Catch::Contains("[1/1] extract") && !Catch::Contains("repair"));
        const auto early = run_frontmesh("run recipe.yaml --from refine", dir);
        CHECK(early.exit_code == 2);
        CHECK_THAT(early.err, Catch::Contains("04-tetra.vtu") &&
                                  Catch::Contains("run the earlier stages first"));
    }
}

TEST_CASE("bad input: one clear line, exit code 2, nothing written", "[pipeline]") {
    const std::string dir = phantom_run_dir("run_bad");
    auto expect_clean_failure = [&](const std::string& args, const std::string& needle) {
        const auto r = run_frontmesh(args + " --quiet", dir);
        INFO(args << "\n" << r.err);
        CHECK(r.exit_code == 2);
        CHECK_THAT(r.err, Catch::Contains(needle));
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);  // one line
        CHECK_FALSE(fs::exists(fs::path(dir) / "out"));
    };
    write_file(dir + "/typo.yaml",
               "input:\n  image: phantom.mha\n  lables: [1]\noutput:\n  dir: out\n");
    expect_clean_failure("run typo.yaml", "did you mean 'input.labels'");
    write_file(dir + "/missing.yaml", "input:\n  image: nothere.nii.gz\noutput:\n  dir: out\n");
    expect_clean_failure("run missing.yaml", "nothere.nii.gz");
    expect_clean_failure("run recipe.yaml --set input.labels=[9]", "label 9 is not in");
    expect_clean_failure("run recipe.yaml --set input.labels=[]", "input.labels");
    fixtures::write_metaimage(fixtures::sphere_image(8, 0.1),
                              dir + "/empty.mha");  // no voxel inside
    expect_clean_failure("run recipe.yaml --set input.image=empty.mha", "no labelled");
    expect_clean_failure("run recipe.yaml --bogus", "--bogus");
    expect_clean_failure("frobnicate recipe.yaml", "unknown command");
    CHECK(run_frontmesh("validate recipe.yaml", dir).exit_code == 0);
    CHECK(run_frontmesh("validate typo.yaml", dir).exit_code == 2);
}

TEST_CASE("help, version and keys commands", "[pipeline]") {
    const std::string dir = fixtures::temp_dir("run_help");
    const auto help = run_frontmesh("--help", dir);
    CHECK(help.exit_code == 0);
    CHECK_THAT(help.out,
               Catch::Contains("frontmesh run RECIPE.yaml") && Catch::Contains("Exit codes"));
    const auto version = run_frontmesh("--version", dir);
    CHECK(version.exit_code == 0);
    CHECK(std::regex_search(version.out, std::regex("^frontmesh [0-9]+\\.[0-9]+\\.[0-9]+")));
    const auto keys = run_frontmesh("keys", dir);
    CHECK_THAT(keys.out, Catch::Contains("repair.max_hole_edges: 200"));
    CHECK(run_frontmesh("", dir).exit_code == 2);
}

TEST_CASE("Colin27 brain: closed surface passes meshcheck, checkpoints read by VTK",
          "[pipeline][asan-slow][e2e]") {
    const std::string dir = fixtures::temp_dir("run_colin27");
    const std::string recipe = std::string(FRONTMESH_SOURCE_DIR) + "/examples/colin27-brain.yaml";
    const auto r = run_frontmesh(
        "run '" + recipe + "' --quiet --until repair --set output.dir=" + dir + "/out", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const std::string referee = fixtures::meshcheck_path();
    const std::string check = "/usr/bin/python3 '" + referee + "' '" + dir +
                              "/out/surface.vtu' --json '" + dir + "/meshcheck.json' > '" + dir +
                              "/meshcheck.txt' 2>&1";
    if (!referee.empty()) {
        const int status = std::system(check.c_str());
        INFO(slurp(dir + "/meshcheck.txt"));
        CHECK(WEXITSTATUS(status) == 0);
    } else {
        WARN("meshcheck.py not found beside the repository; referee skipped");
    }
    // Every checkpoint opens with plain VTK (what ParaView uses) and carries the arrays.
    const std::string py =
        "import sys, vtk\n"
        "for f in sys.argv[1:]:\n"
        "    r = vtk.vtkXMLUnstructuredGridReader(); r.SetFileName(f); r.Update(); g = "
        "r.GetOutput()\n"
        "    assert g.GetNumberOfCells() > 1000, f\n"
        "    for a in ('region_in', 'region_out', 'eta', 'min_angle'):\n"
        "        assert g.GetCellData().GetArray(a) is not None, (f, a)\n"
        "    frame = g.GetFieldData().GetArray('frame')\n"
        "    assert ''.join(chr(int(frame.GetTuple1(i))) for i in "
        "range(frame.GetNumberOfTuples())) == 'lps'\n"
        "    import meshio\n"
        "    m = meshio.read(f)\n"  // other tools read our checkpoints too
        "    assert len(m.points) == g.GetNumberOfPoints(), f\n";
    write_file(dir + "/check.py", py);
    const std::string cmd = "/usr/bin/python3 '" + dir + "/check.py' '" + dir +
                            "/out/checkpoints/01-extract.vtu' '" + dir +
                            "/out/checkpoints/02-repair.vtu' > '" + dir + "/py.txt' 2>&1";
    const int status = std::system(cmd.c_str());
    INFO(slurp(dir + "/py.txt"));
    CHECK(WEXITSTATUS(status) == 0);
}

TEST_CASE("AAL atlas: 116 closed, oriented regions through the command line",
          "[pipeline][asan-slow][e2e]") {
    const std::string dir = fixtures::temp_dir("run_aal");
    const std::string recipe = std::string(FRONTMESH_SOURCE_DIR) + "/examples/aal-atlas.yaml";
    const auto r = run_frontmesh(
        "run '" + recipe + "' --quiet --until repair --set output.dir=" + dir + "/out", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const std::string summary = slurp(dir + "/out/summary.json");
    CHECK_THAT(
        summary,
        Catch::Contains("\"regions\": 116, \"regions_closed\": 116, \"regions_oriented\": 116") &&
            Catch::Contains("\"frame\": \"ras\""));
}

TEST_CASE("checkpoints are identical byte for byte across runs and thread counts", "[pipeline]") {
    const std::string dir = phantom_run_dir("run_determinism");
    REQUIRE(run_frontmesh("run recipe.yaml --quiet --threads 1", dir).exit_code == 0);
    std::vector<std::string> first;
    const char* checkpoints[] = {"01-extract.vtu", "02-repair.vtu", "04-tetra.vtu",
                                 "05-refine.vtu"};
    for (const char* c : checkpoints) first.push_back(slurp(fs::path(dir) / "out/checkpoints" / c));
    REQUIRE(run_frontmesh("run recipe.yaml --quiet --force --threads 2", dir).exit_code == 0);
    for (std::size_t i = 0; i < first.size(); ++i) {
        INFO(checkpoints[i]);
        CHECK(first[i].size() > 10000);
        CHECK(slurp(fs::path(dir) / "out/checkpoints" / checkpoints[i]) == first[i]);
    }
}

TEST_CASE("a surface input enters at repair and keeps its regions", "[pipeline]") {
    const std::string dir = phantom_run_dir("run_surface_input");
    REQUIRE(run_frontmesh("run recipe.yaml --quiet --until repair", dir).exit_code == 0);
    write_file(dir + "/surface.yaml",
               "input:\n  surface: out/surface.vtu\noutput:\n  dir: again\n");
    const auto r = run_frontmesh("run surface.yaml --until repair", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.err, Catch::Contains("reading surface") && Catch::Contains("[2/2] repair"));
    CHECK_FALSE(fs::exists(fs::path(dir) / "again/checkpoints/01-extract.vtu"));
    CHECK_THAT(slurp(fs::path(dir) / "again/summary.json"),
               Catch::Contains("\"regions_closed\": 3"));
    const auto from_extract = run_frontmesh("run surface.yaml --quiet --from extract", dir);
    CHECK(from_extract.exit_code == 2);
    CHECK_THAT(from_extract.err, Catch::Contains("extract") && Catch::Contains("needs an image"));
    write_file(dir + "/broken.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
    const auto bad = run_frontmesh("run surface.yaml --quiet --set input.surface=broken.off", dir);
    CHECK(bad.exit_code == 2);
    CHECK_THAT(bad.err, Catch::Contains("broken.off"));
}

TEST_CASE(
    "remesh stage: 03-remesh.vtu with eta, min_angle, regions and target_size, and its quality",
    "[pipeline]") {
    const std::string dir = phantom_run_dir("run_remesh");
    // The volume limit makes a region that loses more mesh again finer (the phantom's inner
    // shell loses about 0.51% at 1.5 mm without it).
    const auto r = run_frontmesh(
        "run recipe.yaml --quiet --until remesh --set remesh.edge_length=1.5 --set "
        "remesh.max_volume_change_percent=0.4",
        dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const fs::path out = fs::path(dir) / "out";
    const std::string vtu = slurp(out / "checkpoints/03-remesh.vtu");
    for (const char* name : {"Name=\"eta\"", "Name=\"min_angle\"", "Name=\"region_in\"",
                             "Name=\"region_out\"", "Name=\"target_size\""})
        CHECK_THAT(vtu, Catch::Contains(name));
    CHECK(fs::exists(out / "surface.vtu"));
    // The figures of the acceptance are in the summary: every region closed and oriented,
    // no face under 20 degrees, volumes kept.
    const std::string summary = slurp(out / "summary.json");
    CHECK_THAT(summary, Catch::Contains("\"name\": \"remesh\""));
    const std::smatch m = [&] {
        std::smatch found;
        std::regex_search(summary, found, std::regex("\"remesh.min_angle_deg\": ([0-9.eE+-]+)"));
        return found;
    }();
    REQUIRE(m.size() == 2);
    CHECK(std::stod(m[1]) >= 20.0);
    std::smatch v;
    std::string rest = summary;
    int regions = 0;
    while (std::regex_search(
        rest, v, std::regex("\"remesh.volume_change_percent.region_[0-9]+\": ([0-9.eE+-]+)"))) {
        CHECK(std::abs(std::stod(v[1])) <= 0.5);
        ++regions;
        rest = v.suffix();
    }
    CHECK(regions == 3);
    // Nothing is rewritten when the remesh parameters do not change; a new h runs it again.
    const auto again = run_frontmesh(
        "run recipe.yaml --until remesh --set remesh.edge_length=1.5 --set "
        "remesh.max_volume_change_percent=0.4",
        dir);
    CHECK_THAT(again.err, Catch::Contains("up to date"));
    const auto other =
        run_frontmesh("run recipe.yaml --until remesh --set remesh.edge_length=2", dir);
    CHECK(other.exit_code == 0);
    CHECK_THAT(other.err, Catch::Contains("[3/3] remesh"));
}

TEST_CASE("summary.json names the components not meshed and a tiny image still meshes",
          "[pipeline]") {
    SECTION("a one-voxel island under repair.min_component_volume_mm3") {
        const std::string dir = fixtures::temp_dir("run_dropped_components");
        auto image = fixtures::sphere_image(24, 6.0, 1.0, 1);
        image.labels[image.index(20, 3, 20)] = 2;
        fixtures::write_metaimage(image, dir + "/island.mha");
        write_file(dir + "/recipe.yaml",
                   "input:\n  image: island.mha\noutput:\n  dir: out\n"
                   "repair:\n  min_component_volume_mm3: 2\n");
        const auto r = run_frontmesh("run recipe.yaml --quiet --until repair", dir);
        INFO(r.err);
        REQUIRE(r.exit_code == 0);
        const std::string summary = slurp(fs::path(dir) / "out" / "summary.json");
        CHECK_THAT(summary, Catch::Contains("\"dropped_components\": [{\"label\": 2, "
                                            "\"voxels\": 1, \"position_mm\": [") &&
                                Catch::Contains("label 2 is not meshed at all"));
        CHECK_THAT(r.err, Catch::Contains("label 2: component of 1 voxel"));
    }
    SECTION("2 x 2 x 2 voxels of 100 mm, three labels, through repair") {
        const std::string dir = fixtures::temp_dir("run_tiny_cube");
        core::LabelImage image;
        image.dims = {2, 2, 2};
        image.spacing = Eigen::Vector3d::Constant(100.0);
        image.labels = {1, 1, 1, 1, 2, 2, 3, 3};
        fixtures::write_metaimage(image, dir + "/cube.mha");
        write_file(dir + "/recipe.yaml", "input:\n  image: cube.mha\noutput:\n  dir: out\n");
        const auto r = run_frontmesh("run recipe.yaml --quiet --until repair", dir);
        INFO(r.err);
        CHECK(r.exit_code == 0);
        CHECK_THAT(slurp(fs::path(dir) / "out" / "summary.json"),
                   Catch::Contains("\"regions_closed\": 3") &&
                       Catch::Contains("\"dropped_components\": []"));
    }
}
