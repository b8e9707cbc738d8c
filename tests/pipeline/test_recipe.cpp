#include <filesystem>
#include <fstream>
#include <regex>

#include <catch2/catch.hpp>

#include "pipeline/core/error.h"
#include "pipeline/recipe.h"
#include "tests/fixtures/phantoms.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::write_file;

namespace {

// Loads a recipe written from `text` and returns the InputError message ("" if none).
std::string error_of(const std::string& text, const std::vector<std::string>& overrides = {}) {
    const std::string dir = fixtures::temp_dir("recipe");
    fixtures::write_metaimage(fixtures::sphere_image(8, 2.0), dir + "/ball.mha");
    write_file(dir + "/r.yaml", text);
    try {
        pipeline::load_recipe(dir + "/r.yaml", overrides);
    } catch (const core::InputError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE("a valid recipe is typed with defaults and relative paths resolved", "[pipeline]") {
    const std::string dir = fixtures::temp_dir("recipe_ok");
    fixtures::write_metaimage(fixtures::sphere_image(8, 2.0), dir + "/ball.mha");
    write_file(dir + "/r.yaml", "input:\n  image: ball.mha\n  labels: [1]\nextract:\n  smoothing_iterations: 3\n");
    const auto r = pipeline::load_recipe(dir + "/r.yaml", {"extract.blur_sigma_mm=0.5", "output.frame=ras"});
    CHECK(r.input.image == (std::filesystem::path(dir) / "ball.mha").lexically_normal().string());
    CHECK(r.input.labels == std::vector<core::Label>{1});
    CHECK(r.extract.labels == std::vector<core::Label>{1});
    CHECK(r.extract.smoothing_iterations == 3);
    CHECK(r.extract.blur_sigma_mm == 0.5);
    CHECK(r.output.frame == core::Frame::Ras);
    CHECK(r.repair.max_hole_edges == 200);  // default
    CHECK(std::filesystem::path(r.output.dir).is_absolute());
}

TEST_CASE("recipe errors: one line naming file, line and key", "[pipeline]") {
    SECTION("misspelled key, with a suggestion") {
        const auto e = error_of("input:\n  image: ball.mha\nextract:\n  smoothing_iteration: 3\n");
        CHECK_THAT(e, Catch::Contains("r.yaml:4") && Catch::Contains("extract.smoothing_iteration") &&
                          Catch::Contains("did you mean 'extract.smoothing_iterations'"));
    }
    SECTION("misspelled section") {
        const auto e = error_of("input:\n  image: ball.mha\nrepiar:\n  fill_holes: false\n");
        CHECK_THAT(e, Catch::Contains("r.yaml:4") && Catch::Contains("repair.fill_holes"));
    }
    SECTION("wrong type") {
        const auto e = error_of("input:\n  image: ball.mha\nrepair:\n  fill_holes: maybe\n");
        CHECK_THAT(e, Catch::Contains("r.yaml:4") && Catch::Contains("repair.fill_holes") &&
                          Catch::Contains("true or false"));
    }
    SECTION("out of range") {
        const auto e = error_of("input:\n  image: ball.mha\nextract:\n  smoothing_relaxation: 2\n");
        CHECK_THAT(e, Catch::Contains("r.yaml:4") && Catch::Contains("extract.smoothing_relaxation") &&
                          Catch::Contains("must be in"));
    }
    SECTION("unknown choice") {
        const auto e = error_of("input:\n  image: ball.mha\noutput:\n  frame: mni\n");
        CHECK_THAT(e, Catch::Contains("output.frame") && Catch::Contains("lps, ras"));
    }
    SECTION("missing image") {
        const auto e = error_of("input:\n  image: nowhere.nii.gz\n");
        CHECK_THAT(e, Catch::Contains("r.yaml:2") && Catch::Contains("input.image") &&
                          Catch::Contains("nowhere.nii.gz") && Catch::Contains("does not exist"));
    }
    SECTION("empty label list") {
        const auto e = error_of("input:\n  image: ball.mha\n  labels: []\n");
        CHECK_THAT(e, Catch::Contains("input.labels") && Catch::Contains("empty"));
    }
    SECTION("label zero") {
        CHECK_THAT(error_of("input:\n  image: ball.mha\n  labels: [0, 2]\n"), Catch::Contains("input.labels"));
    }
    SECTION("neither image nor surface") {
        CHECK_THAT(error_of("output:\n  dir: x\n"), Catch::Contains("input.image or input.surface"));
    }
    SECTION("YAML syntax") {
        CHECK_THAT(error_of("input:\n  image: [ball.mha\n"), Catch::Contains("YAML syntax error"));
    }
    SECTION("remesh keys are typed and range-checked") {
        CHECK_THAT(error_of("input:\n  image: ball.mha\nremesh:\n  edge_length: -2\n"),
                   Catch::Contains("r.yaml:4") && Catch::Contains("remesh.edge_length"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\nremesh:\n  gradation: 0.5\n"),
                   Catch::Contains("remesh.gradation"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\nremesh:\n  label_edge_length: [1, 2]\n"),
                   Catch::Contains("remesh.label_edge_length") && Catch::Contains("mapping"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\nremesh:\n  edge_lenght: 2\n"),
                   Catch::Contains("did you mean 'remesh.edge_length'"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\nextract:\n  closing_voxels: 11\n"),
                   Catch::Contains("extract.closing_voxels"));
    }
    SECTION("volume stage keys are range-checked with their place") {
        CHECK_THAT(error_of("input:\n  image: ball.mha\ntetra:\n  stretching: 1.0\n"),
                   Catch::Contains("r.yaml:4") && Catch::Contains("tetra.stretching") &&
                       Catch::Contains("greater than 1"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\nrefine:\n  passes: many\n"),
                   Catch::Contains("refine.passes") && Catch::Contains("whole number"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\nrefine:\n  flip_skewnes: 0.3\n"),
                   Catch::Contains("did you mean 'refine.flip_skewness'"));
        CHECK(error_of("input:\n  image: ball.mha\ntetra:\n  stretching: 1.05\nrefine:\n  passes: 2\n") == "");
    }
    SECTION("--set errors name the override") {
        CHECK_THAT(error_of("input:\n  image: ball.mha\n", {"extract.methd=auto"}),
                   Catch::Contains("--set") && Catch::Contains("did you mean 'extract.method'"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\n", {"repair.max_hole_edges=-4"}),
                   Catch::Contains("--set") && Catch::Contains("repair.max_hole_edges"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\n", {"noequals"}), Catch::Contains("key.path=value"));
    }
    SECTION("a valid recipe has no error") { CHECK(error_of("input:\n  image: ball.mha\n") == ""); }
}

TEST_CASE("configs/reference.yaml documents every key with its default, and is valid", "[pipeline]") {
    const std::string path = std::string(FRONTMESH_SOURCE_DIR) + "/configs/reference.yaml";
    const std::string text = frontmesh::testing::slurp(path);
    for (const auto& [key, value] : pipeline::recipe_keys()) {
        INFO(key);
        const std::string leaf = key.substr(key.find('.') + 1);
        if (key == "input.image") continue;  // the reference names an example image
        // "  leaf: default" somewhere below its section.
        const std::regex line("\\n  " + leaf + ": " + std::regex_replace(value, std::regex("[.\\[\\]{}]"), "\\$&") + "\\s");
        CHECK(std::regex_search(text, line));
    }
    CHECK_NOTHROW(pipeline::load_recipe(path));
}
