#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <type_traits>
#include <variant>

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
    write_file(dir + "/r.yaml",
               "input:\n  image: ball.mha\n  labels: [1]\nextract:\n  smoothing_iterations: 3\n");
    const auto r =
        pipeline::load_recipe(dir + "/r.yaml", {"extract.blur_sigma_mm=0.5", "output.frame=ras"});
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
        CHECK_THAT(e, Catch::Contains("r.yaml:4") &&
                          Catch::Contains("extract.smoothing_iteration") &&
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
        CHECK_THAT(e, Catch::Contains("r.yaml:4") &&
                          Catch::Contains("extract.smoothing_relaxation") &&
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
    SECTION("an image name too long for the file system") {
        // fs::exists threw filesystem_error (ENAMETOOLONG) here: an internal error, exit 1
        // (found by fuzz_recipe).
        const std::string name(300, 'a');
        const auto e = error_of("input:\n  image: " + name + ".nii\n");
        CHECK_THAT(e, Catch::Contains("r.yaml:2") && Catch::Contains("input.image") &&
                          Catch::Contains("cannot be examined"));
    }
    SECTION("empty label list") {
        const auto e = error_of("input:\n  image: ball.mha\n  labels: []\n");
        CHECK_THAT(e, Catch::Contains("input.labels") && Catch::Contains("empty"));
    }
    SECTION("label zero") {
        CHECK_THAT(error_of("input:\n  image: ball.mha\n  labels: [0, 2]\n"),
                   Catch::Contains("input.labels"));
    }
    SECTION("neither image nor surface") {
        CHECK_THAT(error_of("output:\n  dir: x\n"),
                   Catch::Contains("input.image or input.surface"));
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
        CHECK(
            error_of(
                "input:\n  image: ball.mha\ntetra:\n  stretching: 1.05\nrefine:\n  passes: 2\n") ==
            "");
    }
    SECTION("--set errors name the override") {
        CHECK_THAT(error_of("input:\n  image: ball.mha\n", {"extract.methd=auto"}),
                   Catch::Contains("--set") && Catch::Contains("did you mean 'extract.method'"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\n", {"repair.max_hole_edges=-4"}),
                   Catch::Contains("--set") && Catch::Contains("repair.max_hole_edges"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\n", {"noequals"}),
                   Catch::Contains("key.path=value"));
    }
    SECTION("output.split_interfaces: none, all or label pairs") {
        const std::string in = "input:\n  image: ball.mha\n  labels: [1, 2, 3]\noutput:\n";
        CHECK(error_of(in + "  split_interfaces: [[1, 2], [3, 2]]\n") == "");
        CHECK(error_of(in + "  split_interfaces: all\n") == "");
        CHECK(error_of(in + "  split_interfaces: none\n") == "");
        CHECK_THAT(error_of(in + "  split_interfaces: some\n"),
                   Catch::Contains("r.yaml:5") && Catch::Contains("output.split_interfaces") &&
                       Catch::Contains("none, all"));
        CHECK_THAT(error_of(in + "  split_interfaces: [1, 2]\n"),
                   Catch::Contains("output.split_interfaces") &&
                       Catch::Contains("a pair of labels such as [1, 2]"));
        CHECK_THAT(
            error_of(in + "  split_interfaces: [[2, 2]]\n"),
            Catch::Contains("output.split_interfaces") && Catch::Contains("two different labels"));
        CHECK_THAT(error_of(in + "  split_interfaces: [[1, 2], [2, 1]]\n"),
                   Catch::Contains("listed twice"));
        CHECK_THAT(error_of(in + "  split_interfaces: [[0, 2]]\n"),
                   Catch::Contains("output.split_interfaces"));
        CHECK_THAT(error_of(in + "  split_interfaces: [[1, 5]]\n"),
                   Catch::Contains("r.yaml:5: output.split_interfaces: label 5 is not in "
                                   "input.labels"));
    }
    SECTION("a key that is not a name") {
        // Found by fuzz_recipe (issue 21): yaml-cpp's bad conversion escaped as exit 1.
        CHECK_THAT(error_of("? {image: a}\n: x\n"),
                   Catch::Contains("r.yaml:1") && Catch::Contains("a key must be a plain name"));
        CHECK_THAT(error_of("input:\n  ? [image]\n  : ball.mha\n"),
                   Catch::Contains("r.yaml:2") && Catch::Contains("a key must be a plain name"));
    }
    SECTION("aliases: a cycle, a bomb, deep nesting") {
        // Found by the malformed-input campaign (issue 21): `&a [*a]` crashed (SIGSEGV) and
        // nine anchors of ten aliases each did not end.
        CHECK_THAT(error_of("input:\n  image: ball.mha\nextra: &a [*a]\n"),
                   Catch::Contains("r.yaml:3") && Catch::Contains("a cycle"));
        std::string bomb = "[x, x, x, x, x, x, x, x, x, x]";
        for (int level = 0; level < 9; ++level) {
            const std::string a = "a" + std::to_string(level);
            std::string next = "[&" + a + " " + bomb;
            for (int i = 0; i < 9; ++i) next += ", *" + a;
            bomb = next + "]";
        }
        CHECK_THAT(error_of("input:\n  image: ball.mha\n  labels: " + bomb + "\n"),
                   Catch::Contains("r.yaml:3") && Catch::Contains("more than 100000 values"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\n", {"input.labels=" + bomb}),
                   Catch::Contains("--set input.labels: more than 100000 values"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\nextra: " + std::string(100, '[') +
                            std::string(100, ']') + "\n"),
                   Catch::Contains("r.yaml:3") && Catch::Contains("nested more than 64"));
        // An anchor used as intended is still read.
        CHECK(error_of("input:\n  image: ball.mha\nremesh:\n  edge_length: &h 2\ntetra:\n"
                       "  max_edge_length: *h\n") == "");
    }
    SECTION("an unknown section, also an empty one") {
        CHECK_THAT(error_of("input:\n  image: ball.mha\nlabel_edge_length: {}\n"),
                   Catch::Contains("r.yaml:3") && Catch::Contains("label_edge_length"));
    }
    SECTION("a recipe is UTF-8 text") {
        // Campaign seed 5 (issue 21): random bytes in output.dir made a folder of that name.
        CHECK_THAT(error_of("input:\n  image: ball.mha\noutput:\n  dir: ou\xef*\xdb\xd9\n"),
                   Catch::Contains("r.yaml:4: not UTF-8 text (byte 0xef)"));
        CHECK_THAT(error_of("input:\n  image: ball.mha\n  labels: [1] # \xed\xa0\x80\n"),
                   Catch::Contains("r.yaml:3: not UTF-8"));  // a surrogate
        CHECK_THAT(error_of("input:\n  image: ball.mha\n", {"output.dir=a\xc0\xaf"
                                                            "b"}),
                   Catch::Contains("--set output.dir: not UTF-8"));  // an overlong '/'
        CHECK(error_of("input:\n  image: ball.mha\noutput:\n  dir: "
                       "\xc3\x9c"
                       "n"
                       "\xc3\xaf"
                       "c\xf0\x9f\x98\x80\n") == "");
    }
    SECTION("a --set of null unsets what the file gave") {
        // `--set input.image=` meshed the file's image, recorded as null (campaign seed 4).
        CHECK_THAT(error_of("input:\n  image: ball.mha\n", {"input.image="}),
                   Catch::Contains("exactly one of input.image or input.surface"));
        // An empty text is no path: fs::absolute("") threw (campaign seed 19: exit 1).
        for (const char* key : {"input.image", "input.surface", "input.label_names"})
            CHECK_THAT(error_of("input:\n  image: ball.mha\n", {std::string(key) + "=''"}),
                       Catch::Contains(std::string("--set: ") + key) &&
                           Catch::Contains("expected a non-empty text"));
        const std::string dir = fixtures::temp_dir("recipe_unset");
        fixtures::write_metaimage(fixtures::sphere_image(8, 2.0), dir + "/ball.mha");
        write_file(dir + "/r.yaml", "input:\n  image: ball.mha\n  threshold: 0.5\n");
        CHECK(pipeline::load_recipe(dir + "/r.yaml").input.threshold == 0.5);
        CHECK_FALSE(pipeline::load_recipe(dir + "/r.yaml", {"input.threshold=null"})
                        .input.threshold.has_value());
    }
    SECTION("a valid recipe has no error") { CHECK(error_of("input:\n  image: ball.mha\n") == ""); }
}

TEST_CASE("configs/reference.yaml documents every key with its default, and is valid",
          "[pipeline]") {
    const std::string path = std::string(FRONTMESH_SOURCE_DIR) + "/configs/reference.yaml";
    const std::string text = frontmesh::testing::slurp(path);
    for (const auto& [key, value, range, unit, doc] : pipeline::recipe_keys()) {
        INFO(key);
        const std::string leaf = key.substr(key.find('.') + 1);
        if (key == "input.image") continue;  // the reference names an example image
        // "  leaf: default" somewhere below its section.
        const std::regex line("\\n  " + leaf + ": " +
                              std::regex_replace(value, std::regex("[.\\[\\]{}]"), "\\$&") + "\\s");
        CHECK(std::regex_search(text, line));
    }
    CHECK_NOTHROW(pipeline::load_recipe(path));
}

namespace {

// The value a typed member of `params` is set to (for the range tests).
template <typename Params>
void set_field(Params& params, const typename core::ParamSpec<Params>::Field& field, double v) {
    std::visit(
        [&](auto member) {
            if constexpr (!std::is_same_v<decltype(member), std::monostate>)
                params.*member = static_cast<std::remove_reference_t<decltype(params.*member)>>(v);
        },
        field);
}

template <typename Params>
bool is_number(const core::ParamSpec<Params>& spec) {
    return !std::holds_alternative<std::monostate>(spec.field) &&
           !std::holds_alternative<bool Params::*>(spec.field);
}

template <typename Params>
bool is_whole(const core::ParamSpec<Params>& spec) {
    return is_number(spec) && !std::holds_alternative<double Params::*>(spec.field);
}

template <typename Params>
double declared_default(const core::ParamSpec<Params>& spec) {
    const std::string text(spec.default_yaml);
    return text == "true" ? 1.0 : text == "false" ? 0.0 : std::stod(text);
}

// Every typed key: its declared default is the struct's member default and lies in its
// range; validate() rejects a value just outside either end, naming the key.
template <typename Params>
void check_declarations(const core::ParamTable<Params>& table, const std::string& section) {
    const Params defaults{};
    CHECK_NOTHROW(validate(defaults));
    for (const auto& spec : table) {
        INFO(spec.key);
        CHECK(spec.key.substr(0, section.size() + 1) == section + ".");
        CHECK_FALSE(spec.doc.empty());
        if (std::holds_alternative<std::monostate>(spec.field)) continue;
        CHECK(core::field_value(defaults, spec.field) == declared_default(spec));
        if (!is_number(spec)) continue;
        CHECK(spec.range.contains(declared_default(spec)));
        for (const double outside : {spec.range.lo_open ? spec.range.lo : spec.range.lo - 1.0,
                                     spec.range.hi_open ? spec.range.hi : spec.range.hi + 1.0}) {
            if (std::isinf(outside) ||
                (outside < 0.0 && std::holds_alternative<std::size_t Params::*>(spec.field)))
                continue;
            Params p{};
            set_field(p, spec.field, outside);
            CHECK_THROWS_WITH(validate(p), Catch::StartsWith(std::string(spec.key) + ": must be"));
        }
    }
}

// A value of `spec` other than its default, as YAML text: "" when none is found.
template <typename Params>
std::string other_value(const core::ParamSpec<Params>& spec) {
    const double d = declared_default(spec);
    if (!is_number(spec)) return d == 1.0 ? "false" : "true";
    for (const double v : {d + 1.0, d - 1.0, (spec.range.lo + spec.range.hi) / 2.0, d / 2.0}) {
        if (v == d || !spec.range.contains(v) || (is_whole(spec) && v != std::floor(v))) continue;
        std::ostringstream s;
        s.precision(17);
        s << v;
        return s.str();
    }
    return "";
}

// Setting any typed key to another value changes its stage's canonical parameters (the
// stage hash): canonical_params() lists every key of the table.
template <typename Params>
void check_hashed(const core::ParamTable<Params>& table, const std::string& section,
                  const std::string& recipe) {
    const std::string before = pipeline::canonical_params(pipeline::load_recipe(recipe), section);
    for (const auto& spec : table) {
        if (std::holds_alternative<std::monostate>(spec.field)) continue;
        INFO(spec.key);
        const std::string value = other_value(spec);
        REQUIRE_FALSE(value.empty());
        const auto changed = pipeline::load_recipe(recipe, {std::string(spec.key) + "=" + value});
        CHECK(pipeline::canonical_params(changed, section) != before);
    }
}

}  // namespace

TEST_CASE("each stage declares every key once: defaults, ranges and validate agree", "[pipeline]") {
    check_declarations(surface::extract_keys(), "extract");
    check_declarations(surface::repair_keys(), "repair");
    check_declarations(surface::remesh_keys(), "remesh");
    check_declarations(volume::tetra_keys(), "tetra");
    check_declarations(volume::refine_keys(), "refine");

    // Hand-read keys too: a recipe without stage keys gives exactly the structs' defaults.
    const std::string dir = fixtures::temp_dir("recipe_defaults");
    fixtures::write_metaimage(fixtures::sphere_image(8, 2.0), dir + "/ball.mha");
    write_file(dir + "/r.yaml", "input:\n  image: ball.mha\n");
    const pipeline::Recipe loaded = pipeline::load_recipe(dir + "/r.yaml");
    pipeline::Recipe defaults;
    defaults.input = loaded.input;
    for (const std::string section : {"extract", "repair", "remesh", "tetra", "refine"}) {
        INFO(section);
        CHECK(pipeline::canonical_params(loaded, section) ==
              pipeline::canonical_params(defaults, section));
    }

    // Keys are unique and every stage key is a recipe key.
    std::set<std::string> keys;
    for (const auto& k : pipeline::recipe_keys()) CHECK(keys.insert(k.key).second);
    CHECK(keys.count("tetra.stretching") == 1);
    CHECK(keys.count("extract.closing_voxels") == 1);
}

TEST_CASE("every stage key is part of its stage's hash", "[pipeline]") {
    const std::string dir = fixtures::temp_dir("recipe_hashed");
    fixtures::write_metaimage(fixtures::sphere_image(8, 2.0), dir + "/ball.mha");
    write_file(dir + "/r.yaml", "input:\n  image: ball.mha\n");
    const std::string recipe = dir + "/r.yaml";
    check_hashed(surface::extract_keys(), "extract", recipe);
    check_hashed(surface::repair_keys(), "repair", recipe);
    check_hashed(surface::remesh_keys(), "remesh", recipe);
    check_hashed(volume::tetra_keys(), "tetra", recipe);
    check_hashed(volume::refine_keys(), "refine", recipe);
    const auto base = pipeline::load_recipe(recipe);
    CHECK(pipeline::canonical_params(pipeline::load_recipe(recipe, {"extract.method=surface_nets"}),
                                     "extract") != pipeline::canonical_params(base, "extract"));
    CHECK(pipeline::canonical_params(
              pipeline::load_recipe(recipe, {"remesh.label_edge_length={1: 2.0}"}), "remesh") !=
          pipeline::canonical_params(base, "remesh"));
}

TEST_CASE("hand-read keys use their declared choices and ranges", "[pipeline]") {
    CHECK_THAT(
        error_of("input:\n  image: ball.mha\nextract:\n  method: marching\n"),
        Catch::Contains("extract.method") && Catch::Contains("auto, flying_edges, surface_nets"));
    CHECK_THAT(error_of("input:\n  image: ball.mha\nremesh:\n  label_edge_length: {3: 20000}\n"),
               Catch::Contains("remesh.label_edge_length") && Catch::Contains("(0, 10000]"));
    CHECK_THAT(error_of("input:\n  image: ball.mha\nremesh:\n  label_edge_length: {3: 0}\n"),
               Catch::Contains("remesh.label_edge_length") && Catch::Contains("greater than 0"));
    surface::RemeshParams p;
    p.label_edge_length[3] = -1.0;
    CHECK_THROWS_WITH(surface::validate(p), Catch::Contains("remesh.label_edge_length: label 3"));
}
