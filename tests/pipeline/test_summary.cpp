// summary.json (issue 22, item 9): output files, region names, the recipe in effect, the
// input image, timestamps, regions_closed of a tet result, reused stages keeping their
// timings; validated against docs/summary.schema.json by an outside validator.

#include <cstdlib>
#include <filesystem>
#include <regex>

#include <catch2/catch.hpp>

#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/skip.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
using frontmesh::testing::slurp;
using frontmesh::testing::write_file;
namespace fs = std::filesystem;

namespace {

// tests/pipeline/check_summary_schema.py: exit status (3: no jsonschema) and its output.
std::pair<int, std::string> validate(const fs::path& summary, const fs::path& dir) {
    const std::string source = FRONTMESH_SOURCE_DIR;
    const fs::path report = dir / "schema.txt";
    const std::string cmd =
        "/usr/bin/python3 '" + source + "/tests/pipeline/check_summary_schema.py' '" + source +
        "/docs/summary.schema.json' '" + summary.string() + "' > '" + report.string() + "' 2>&1";
    const int status = std::system(cmd.c_str());
    return {WEXITSTATUS(status), slurp(report)};
}

// The text of stage `name`'s entry in a summary.json (up to the next stage's).
std::string stage_entry(const std::string& summary, const std::string& name) {
    const auto at = summary.find("{\"name\": \"" + name + "\"");
    if (at == std::string::npos) return {};
    const auto end =
        std::min(summary.find("{\"name\": \"", at + 1), summary.find("\"diagnostics\"", at));
    return summary.substr(at, end - at);
}

std::string wall_of(const std::string& entry) {
    std::smatch m;
    return std::regex_search(entry, m, std::regex("\"wall_s\": ([0-9.e+-]+)")) ? m[1].str() : "";
}

}  // namespace

TEST_CASE("summary.json lists outputs, names, recipe, image and times and passes its schema",
          "[pipeline][asan-slow][summary]") {
    const std::string dir = fixtures::temp_dir("summary_schema");
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.6), dir + "/phantom.mha");
    write_file(dir + "/phantom.txt", "1 Outer shell\n2 Middle\n3 Core\n");  // beside the image
    write_file(dir + "/recipe.yaml",
               "input:\n  image: phantom.mha\noutput:\n  dir: out\n"
               "  formats: [vtu, msh]\nremesh:\n  edge_length: 1.5\n");
    const auto r = run_frontmesh("run recipe.yaml --quiet --threads 1", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const fs::path out = fs::path(dir) / "out";
    const std::string summary = slurp(out / "summary.json");
    CHECK_THAT(summary, Catch::Contains("{\"label\": 1, \"name\": \"Outer shell\"}") &&
                            Catch::Contains("{\"label\": 3, \"name\": \"Core\"}") &&
                            Catch::Contains("{\"file\": \"mesh.msh\", \"bytes\": ") &&
                            Catch::Contains("{\"file\": \"report.html\", \"bytes\": ") &&
                            Catch::Contains("\"remesh.edge_length\": 1.5") &&
                            Catch::Contains("\"tetra.stretching\": ") &&
                            Catch::Contains("\"label_voxels\": {\"1\": ") &&
                            Catch::Contains("\"spacing_mm\": [1, 1, 1]"));
    // The tet result says how many regions are closed (it said nothing, so the cohort's
    // column stayed empty).
    CHECK_THAT(stage_entry(summary, "refine"), Catch::Contains("\"regions_closed\": 3"));
    CHECK(
        std::regex_search(summary, std::regex("\"started\": \"[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9:]{8}"
                                              "[+-][0-9]{2}:[0-9]{2}\"")));

    const auto [status, text] = validate(out / "summary.json", dir);
    if (status == 3) FM_SKIP("python3-jsonschema is not installed");
    INFO(text);
    CHECK(status == 0);

    // A re-run that changes refine only reuses the other stages with their own timings.
    const std::string tetra_before = stage_entry(summary, "tetra");
    const auto again = run_frontmesh("run recipe.yaml --quiet --set refine.passes=2", dir);
    REQUIRE(again.exit_code == 0);
    const std::string rerun = slurp(out / "summary.json");
    const std::string tetra_after = stage_entry(rerun, "tetra");
    CHECK_THAT(tetra_after, Catch::Contains("\"status\": \"skipped\", \"reused\": true"));
    CHECK(wall_of(tetra_after) == wall_of(tetra_before));
    CHECK_THAT(stage_entry(rerun, "refine"), Catch::Contains("\"reused\": false"));
    CHECK(validate(out / "summary.json", dir).first == 0);

    // A surface result validates too; the schema refuses a summary without its outputs.
    const auto surface = run_frontmesh(
        "run recipe.yaml --quiet --until repair "
        "--set output.dir=surface",
        dir);
    REQUIRE(surface.exit_code == 0);
    CHECK(validate(fs::path(dir) / "surface" / "summary.json", dir).first == 0);
    std::string broken = rerun;
    broken.replace(broken.find("\"outputs\""), 9, "\"outputz\"");
    write_file(dir + "/broken.json", broken);
    CHECK(validate(fs::path(dir) / "broken.json", dir).first == 1);
}

TEST_CASE("summary.json lists only what this run wrote or found up to date",
          "[pipeline][summary]") {
    const std::string dir = fixtures::temp_dir("summary_outputs");
    fixtures::write_metaimage(fixtures::sphere_image(20, 7.0), dir + "/ball.mha");
    write_file(dir + "/recipe.yaml",
               "input:\n  image: ball.mha\noutput:\n  dir: out\n  formats: [vtu, msh, inp]\n");
    const auto first = run_frontmesh("run recipe.yaml --quiet", dir);
    INFO(first.err);
    REQUIRE(first.exit_code == 0);
    const fs::path out = fs::path(dir) / "out";
    CHECK_THAT(slurp(out / "summary.json"),
               Catch::Contains("{\"file\": \"mesh.inp\", \"bytes\": ") &&
                   Catch::Contains("{\"file\": \"run-volume.pvd\", \"bytes\": "));

    // Another format: mesh.inp stays in the folder but is not this run's output.
    const auto second = run_frontmesh("run recipe.yaml --quiet --set output.formats=[vtu]", dir);
    REQUIRE(second.exit_code == 0);
    REQUIRE(fs::exists(out / "mesh.inp"));
    std::string summary = slurp(out / "summary.json");
    CHECK_THAT(summary, !Catch::Contains("\"mesh.inp\"") && !Catch::Contains("\"mesh.msh\"") &&
                            Catch::Contains("{\"file\": \"mesh.vtu\", \"bytes\": ") &&
                            Catch::Contains("{\"file\": \"mesh_surface.vtp\", \"bytes\": ") &&
                            Catch::Contains("{\"file\": \"report.html\", \"bytes\": ") &&
                            Catch::Contains("{\"file\": \"checkpoints/05-refine.vtu\", "));

    // A shorter run: the tet checkpoints of the earlier runs are not its outputs.
    const auto surface = run_frontmesh("run recipe.yaml --quiet --until remesh", dir);
    REQUIRE(surface.exit_code == 0);
    summary = slurp(out / "summary.json");
    CHECK_THAT(summary, Catch::Contains("{\"file\": \"checkpoints/03-remesh.vtu\", ") &&
                            Catch::Contains("{\"file\": \"surface.vtu\", ") &&
                            !Catch::Contains("04-tetra") && !Catch::Contains("\"mesh.vtu\"") &&
                            !Catch::Contains("run-volume.pvd"));
    CHECK(!fs::exists(out / "run-volume.pvd"));
}
