// `frontmesh mesh IMAGE` (issue 22, item 10): the common case without a recipe. It writes
// the recipe it used into the output folder, and that recipe re-runs to the same mesh.

#include <filesystem>
#include <string>

#include <catch2/catch.hpp>

#include "io/mesh_io.h"
#include "tests/fixtures/phantoms.h"
#include "tests/pipeline/cli_helpers.h"
#include "volume/mesh_check.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
using frontmesh::testing::slurp;
namespace fs = std::filesystem;

TEST_CASE("frontmesh mesh: image to mesh with a written recipe that re-runs the same",
          "[pipeline][mesh]") {
    const std::string dir = fixtures::temp_dir("mesh_command");
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.6), dir + "/phantom.mha");
    const auto r = run_frontmesh(
        "mesh phantom.mha -o first --labels 1,2,3 --size 1.5 --format msh,inp --threads 1", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const fs::path first = fs::path(dir) / "first";
    for (const char* f : {"recipe.yaml", "mesh.vtu", "mesh.msh", "mesh.inp", "summary.json"})
        CHECK(fs::exists(first / f));
    const std::string recipe = slurp(first / "recipe.yaml");
    // Every key with its value: the flags, and the defaults of the others.
    CHECK_THAT(recipe, Catch::Contains("labels: [1, 2, 3]") &&
                           Catch::Contains("edge_length: 1.5") &&
                           Catch::Contains("formats: [msh, inp]") && Catch::Contains("tetra:") &&
                           Catch::Contains("refine:") &&
                           Catch::Contains((fs::path(dir) / "phantom.mha").string()));
    const volume::TetMeshCheck check =
        volume::check_tet_mesh(io::read_tet_mesh((first / "mesh.vtu").string()));
    CHECK(check.valid());
    CHECK(check.region_volume.size() == 3);
    // summary.json's outputs list the recipe written into the folder and summary.json itself,
    // with its own size in bytes.
    const std::string summary = slurp(first / "summary.json");
    CHECK_THAT(summary,
               Catch::Contains("{\"file\": \"recipe.yaml\", \"bytes\": " +
                               std::to_string(fs::file_size(first / "recipe.yaml")) + "}") &&
                   Catch::Contains("{\"file\": \"summary.json\", \"bytes\": " +
                                   std::to_string(summary.size()) + "}"));

    // The written recipe, run from another folder into another output, makes the same mesh.
    const std::string other = fixtures::temp_dir("mesh_command_rerun");
    const auto again = run_frontmesh("run '" + (first / "recipe.yaml").string() +
                                         "' --quiet --threads 1 --set output.dir=second",
                                     other);
    INFO(again.err);
    REQUIRE(again.exit_code == 0);
    const fs::path second = fs::path(other) / "second";
    CHECK(slurp(second / "mesh.vtu") == slurp(first / "mesh.vtu"));
    CHECK(slurp(second / "mesh.inp") == slurp(first / "mesh.inp"));
    // Its recipe lies outside that output folder: not one of its outputs.
    const std::string second_summary = slurp(second / "summary.json");
    CHECK_THAT(second_summary, !Catch::Contains("\"recipe.yaml\"") &&
                                   Catch::Contains("{\"file\": \"summary.json\", \"bytes\": " +
                                                   std::to_string(second_summary.size()) + "}"));

    // Sequential checks, not SECTIONs: each SECTION would mesh the phantom again.
    {
        const auto rerun = run_frontmesh(
            "mesh phantom.mha -o first --labels 1,2,3 --size 1.5 --format msh,inp", dir);
        CHECK(rerun.exit_code == 0);
        CHECK_THAT(rerun.err, Catch::Contains("up to date"));
    }
    {
        const auto bad = run_frontmesh("mesh phantom.mha -o third --size -1", dir);
        CHECK(bad.exit_code == 2);
        CHECK_THAT(bad.err, Catch::Contains("edge_length"));
        CHECK_FALSE(fs::exists(fs::path(dir) / "third"));
        const auto labels = run_frontmesh("mesh phantom.mha -o third --labels x,y", dir);
        CHECK(labels.exit_code == 2);
        CHECK_THAT(labels.err, Catch::Contains("--labels"));
        CHECK(run_frontmesh("mesh nothere.mha", dir).exit_code == 2);
        // Refused by the estimate that needs the image: nothing written, not even the recipe
        // (the malformed-input campaign, issue 21: recipe.yaml and the marker were left).
        const auto tiny = run_frontmesh("mesh phantom.mha -o fourth --size 1e-6", dir);
        CHECK(tiny.exit_code == 2);
        CHECK_THAT(tiny.err, Catch::Contains("limits.max_memory_gib"));
        CHECK_FALSE(fs::exists(fs::path(dir) / "fourth"));
    }
    {
        CHECK_THAT(run_frontmesh("--help", dir).out,
                   Catch::Contains("frontmesh mesh IMAGE") && Catch::Contains("--size MM"));
    }
}
