#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <regex>

#include <catch2/catch.hpp>

#include "pipeline/cohort.h"
#include "pipeline/core/error.h"
#include "tests/fixtures/phantoms.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
using frontmesh::testing::slurp;
using frontmesh::testing::write_file;
namespace fs = std::filesystem;

namespace {

using Rows = std::vector<std::vector<std::string>>;

// A folder with three tiny phantoms (two spheres, nested ellipsoids) and a recipe without
// an input (the manifest gives it).
std::string cohort_dir(const std::string& name) {
    const std::string dir = fixtures::temp_dir(name);
    fixtures::write_metaimage(fixtures::sphere_image(20, 6.0), dir + "/small.mha");
    fixtures::write_metaimage(fixtures::sphere_image(20, 7.5), dir + "/large.mha");
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.7), dir + "/ellipsoids.mha");
    write_file(dir + "/recipe.yaml", "output:\n  dir: out\n");
    return dir;
}

// sub-02 keeps two of the ellipsoids' three labels through a quoted cell with a comma;
// sub-03's image does not exist.
const char* kManifest =
    "id,image,input.labels,extract.smoothing_iterations\n"
    "sub-01,small.mha,,\n"
    "sub-02,ellipsoids.mha,\"[1, 2]\",4\n"
    "sub-03,images/missing.mha,,\n";

// The rows of a cohort-summary.csv below its header, as a map from column name.
std::vector<std::map<std::string, std::string>> summary_rows(const fs::path& csv) {
    const auto records = pipeline::parse_csv(slurp(csv), csv.string());
    REQUIRE(!records.empty());
    const auto& header = records.front().second;
    std::vector<std::map<std::string, std::string>> rows;
    for (std::size_t r = 1; r < records.size(); ++r) {
        REQUIRE(records[r].second.size() == header.size());
        std::map<std::string, std::string> row;
        for (std::size_t c = 0; c < header.size(); ++c) row[header[c]] = records[r].second[c];
        rows.push_back(row);
    }
    return rows;
}

// tests/pipeline/check_summary_schema.py with docs/SCHEMA: exit status (3: no jsonschema)
// and its output.
std::pair<int, std::string> validate_with(const fs::path& json, const std::string& schema,
                                          const fs::path& dir) {
    const std::string source = FRONTMESH_SOURCE_DIR;
    const fs::path report = dir / "schema.txt";
    const std::string cmd = "/usr/bin/python3 '" + source +
                            "/tests/pipeline/check_summary_schema.py' '" + source + "/docs/" +
                            schema + "' '" + json.string() + "' > '" + report.string() + "' 2>&1";
    const int status = std::system(cmd.c_str());
    return {WEXITSTATUS(status), slurp(report)};
}

std::map<fs::path, fs::file_time_type> checkpoint_times(const fs::path& root) {
    std::map<fs::path, fs::file_time_type> times;
    for (const auto& e : fs::recursive_directory_iterator(root))
        if (e.path().extension() == ".vtu" && e.path().parent_path().filename() == "checkpoints")
            times[e.path()] = fs::last_write_time(e.path());
    return times;
}

}  // namespace

TEST_CASE("read_manifest: RFC 4180 quoting, relative images, empty cells", "[pipeline]") {
    const std::string dir = fixtures::temp_dir("cohort_manifest");
    write_file(dir + "/m.csv",
               "\xEF\xBB\xBF"
               "id , image,input.labels,extract.blur_sigma_mm\r\n"
               "\r\n"
               "a,img/a.nii.gz,\"[1, 2]\",0.5\r\n"
               "b, /abs/b.mha ,,\r\n"
               "c,\"with \"\"quotes\"\", commas\nand a line break.mha\",all,\n");
    const auto m = pipeline::read_manifest(dir + "/m.csv");
    REQUIRE(m.subjects.size() == 3);
    CHECK(m.columns ==
          std::vector<std::string>{"id", "image", "input.labels", "extract.blur_sigma_mm"});
    CHECK(m.subjects[0].id == "a");
    CHECK(m.subjects[0].image == (fs::path(dir) / "img/a.nii.gz").string());
    CHECK(m.subjects[0].overrides ==
          std::vector<std::pair<std::string, std::string>>{{"input.labels", "[1, 2]"},
                                                           {"extract.blur_sigma_mm", "0.5"}});
    CHECK(m.subjects[0].line == 3);
    CHECK(m.subjects[1].image == "/abs/b.mha");
    CHECK(m.subjects[1].overrides.empty());
    CHECK(m.subjects[2].image ==
          (fs::path(dir) / "with \"quotes\", commas\nand a line break.mha").string());
    CHECK(m.subjects[2].overrides.size() == 1);

    auto error_of = [&](const std::string& text) {
        write_file(dir + "/bad.csv", text);
        try {
            pipeline::read_manifest(dir + "/bad.csv");
        } catch (const core::InputError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    CHECK_THAT(error_of("id,image\na,\"open.mha\n"),
               Catch::Contains("bad.csv:2: a quoted field is not closed"));
    CHECK_THAT(error_of("id,image\na,\"x\"y.mha\n"),
               Catch::Contains("bad.csv:2: text after the closing quote"));
    CHECK_THAT(error_of("id,image\na,x.mha,extra\n"),
               Catch::Contains("bad.csv:2: 3 fields, but the header has 2"));
    CHECK_THAT(error_of("image,id\nx.mha,a\ny.mha,b\nz.mha,a\n"),
               Catch::Contains("bad.csv:4: id 'a' is also on line 2"));
    CHECK_THAT(error_of("id,img\na,x.mha\n"), Catch::Contains("bad.csv:1: no 'image' column"));
    CHECK_THAT(error_of("id,image\n../up,x.mha\n"),
               Catch::Contains("'../up' cannot be a folder name"));
    CHECK_THAT(error_of("id,image\n.hidden,x.mha\n"), Catch::Contains("cannot be a folder name"));
    CHECK_THAT(error_of("id,image\na,\n"), Catch::Contains("empty image"));
    CHECK_THAT(error_of("id,image,output.dir\na,x.mha,o\n"),
               Catch::Contains("column 'output.dir'"));
    CHECK_THAT(error_of("id,image,id\na,x.mha,b\n"), Catch::Contains("column 'id' appears twice"));
    CHECK_THAT(error_of("id,image\n"), Catch::Contains("no subjects"));
    CHECK_THAT(error_of(""), Catch::Contains("the manifest is empty"));
}

TEST_CASE("cohort: a failed subject is recorded, the others finish, a re-run does no work",
          "[pipeline][asan-slow]") {
    const std::string dir = cohort_dir("cohort_run");
    write_file(dir + "/manifest.csv", kManifest);
    const fs::path out = fs::path(dir) / "out";

    const auto first =
        run_frontmesh("cohort manifest.csv --recipe recipe.yaml -j 2 --until repair", dir);
    INFO(first.out << first.err);
    CHECK(first.exit_code == 1);
    for (const char* id : {"sub-01", "sub-02"}) {
        CHECK(fs::exists(out / id / "surface.vtu"));
        CHECK_THAT(slurp(out / id / "summary.json"), Catch::Contains("\"status\": \"ok\""));
        CHECK(fs::exists(out / id / "cohort-run.log"));
    }
    CHECK_FALSE(fs::exists(out / "sub-03" / "summary.json"));
    CHECK_THAT(slurp(out / "sub-03" / "cohort-run.log"),
               Catch::Contains("missing.mha' does not exist"));
    CHECK_THAT(first.err, Catch::Contains("sub-03 failed (exit 2)") &&
                              Catch::Contains("sub-01 ok in") && Catch::Contains("[3/3]"));

    auto rows = summary_rows(out / "cohort-summary.csv");
    REQUIRE(rows.size() == 3);
    CHECK(rows[0]["id"] == "sub-01");
    CHECK(rows[1]["id"] == "sub-02");
    CHECK(rows[2]["id"] == "sub-03");
    for (int i : {0, 1}) {
        CHECK(rows[i]["status"] == "ok");
        CHECK(rows[i]["exit_code"] == "0");
        CHECK(std::stod(rows[i]["faces"]) > 100);
        CHECK(rows[i]["regions_closed"] == rows[i]["regions"]);
        CHECK(rows[i]["tets"].empty());  // a surface result
        CHECK(std::stod(rows[i]["total_wall_s"]) > 0.0);
        CHECK(rows[i]["error"].empty());
    }
    CHECK(rows[0]["regions"] == "1");
    CHECK(rows[1]["regions"] == "2");  // the quoted "[1, 2]" cell picked two of three labels
    CHECK(rows[2]["status"] == "failed");
    CHECK(rows[2]["exit_code"] == "2");
    CHECK_THAT(rows[2]["error"],
               Catch::Contains("input.image") && Catch::Contains("missing.mha' does not exist"));
    // The bad row is named by the manifest's file and line (issue 22), not by the recipe.
    CHECK_THAT(rows[2]["error"], Catch::Contains("manifest.csv:4: subject 'sub-03'"));
    // Region names (labels without a table) and the result files of each subject.
    CHECK(rows[1]["region_names"] == "1;2");
    CHECK_THAT(rows[1]["outputs"], Catch::Contains("surface.vtu") &&
                                       Catch::Contains("summary.json") &&
                                       !Catch::Contains("checkpoints/"));
    CHECK(rows[2]["faces"].empty());
    // Per subject (issue 22): its image, when its run started and finished, the image's
    // dims and spacing as read, and where its summary.json and recipe are.
    const std::regex iso("[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9:]{8}[+-][0-9]{2}:[0-9]{2}");
    for (int i : {0, 1}) {
        CHECK(std::regex_match(rows[i]["started"], iso));
        CHECK(std::regex_match(rows[i]["finished"], iso));
        CHECK(rows[i]["started"] <= rows[i]["finished"]);
        CHECK(rows[i]["image_spacing_mm"] == "1;1;1");
        CHECK(rows[i]["summary"] == (out / rows[i]["id"] / "summary.json").string());
        CHECK(rows[i]["recipe"] == (fs::path(dir) / "recipe.yaml").string());
    }
    CHECK(rows[0]["image"] == (fs::path(dir) / "small.mha").string());
    CHECK(rows[0]["image_dims"] == "20;20;20");
    CHECK(rows[2]["image"] == (fs::path(dir) / "images/missing.mha").string());
    CHECK(rows[2]["started"].empty());  // its run wrote no summary.json
    CHECK(rows[2]["summary"].empty());
    CHECK(rows[2]["image_dims"].empty());
    const std::string json = slurp(out / "cohort-summary.json");
    CHECK_THAT(json,
               Catch::Contains("\"image_dims\": [20, 20, 20], \"image_spacing_mm\": [1, 1, 1]"));
    const auto [schema_status, schema_text] =
        validate_with(out / "cohort-summary.json", "cohort-summary.schema.json", dir);
    INFO(schema_text);
    if (schema_status != 3) CHECK(schema_status == 0);
    // The schema is not empty: a subject without its started time is refused.
    std::string broken = json;
    broken.replace(broken.find("\"started\""), 9, "\"startet\"");
    write_file(dir + "/broken.json", broken);
    if (schema_status != 3)
        CHECK(
            validate_with(fs::path(dir) / "broken.json", "cohort-summary.schema.json", dir).first ==
            1);
    CHECK_THAT(json,
               Catch::Contains("\"counts\": {\"ok\": 2, \"skipped\": 0, \"failed\": 1}") &&
                   Catch::Contains("\"id\": \"sub-03\", \"status\": \"failed\", \"exit_code\": 2"));

    SECTION("a re-run skips the finished subjects and still fails the missing one") {
        const auto times = checkpoint_times(out);
        REQUIRE(times.size() == 4);
        const auto again =
            run_frontmesh("cohort manifest.csv --recipe recipe.yaml -j 2 --until repair", dir);
        INFO(again.err);
        CHECK(again.exit_code == 1);
        CHECK(checkpoint_times(out) == times);
        rows = summary_rows(out / "cohort-summary.csv");
        REQUIRE(rows.size() == 3);
        CHECK(rows[0]["status"] == "skipped");
        CHECK(rows[1]["status"] == "skipped");
        CHECK(rows[2]["status"] == "failed");
        CHECK(rows[1]["regions"] == "2");
        CHECK_THAT(again.err, Catch::Contains("sub-01 skipped"));
    }
    SECTION("a changed cell re-runs that subject only") {
        write_file(dir + "/manifest.csv",
                   std::string(kManifest).replace(std::string(kManifest).find(",4\n"), 3, ",6\n"));
        const auto sub01 = checkpoint_times(out / "sub-01");
        const auto again =
            run_frontmesh("cohort manifest.csv --recipe recipe.yaml --quiet --until repair", dir);
        CHECK(again.exit_code == 1);
        CHECK(again.err.empty());
        CHECK(checkpoint_times(out / "sub-01") == sub01);
        rows = summary_rows(out / "cohort-summary.csv");
        CHECK(rows[0]["status"] == "skipped");
        CHECK(rows[1]["status"] == "ok");
    }
    SECTION("all subjects valid: exit 0, root moved with --set output.dir") {
        write_file(dir + "/valid.csv", "id,image\nsmall,small.mha\nlarge,large.mha\n");
        const auto valid = run_frontmesh(
            "cohort valid.csv --recipe recipe.yaml -j 2 --until repair --set output.dir=valid-out",
            dir);
        INFO(valid.err);
        CHECK(valid.exit_code == 0);
        rows = summary_rows(fs::path(dir) / "valid-out/cohort-summary.csv");
        REQUIRE(rows.size() == 2);
        CHECK(rows[0]["status"] == "ok");
        CHECK(rows[1]["status"] == "ok");
        // The larger ball has the larger surface at the same spacing.
        CHECK(std::stod(rows[1]["faces"]) > std::stod(rows[0]["faces"]));
        CHECK_THAT(valid.out, Catch::Contains("2 ok, 0 skipped (up to date), 0 failed"));
    }
}

TEST_CASE("cohort: a tetrahedral result fills the mesh columns", "[pipeline]") {
    const std::string dir = cohort_dir("cohort_tets");
    write_file(dir + "/manifest.csv", "id,image\nsmall,small.mha\n");
    const auto r = run_frontmesh("cohort manifest.csv --recipe recipe.yaml --quiet", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(fs::exists(fs::path(dir) / "out/small/mesh.vtu"));
    auto rows = summary_rows(fs::path(dir) / "out/cohort-summary.csv");
    REQUIRE(rows.size() == 1);
    CHECK(rows[0]["status"] == "ok");
    CHECK(rows[0]["regions"] == "1");
    CHECK(std::stod(rows[0]["faces"]) > 100);
    CHECK(std::stod(rows[0]["tets"]) > std::stod(rows[0]["faces"]));
    CHECK(std::stod(rows[0]["nodes"]) > 0);
    CHECK(std::stod(rows[0]["min_dihedral_deg"]) > 0.0);
    CHECK(std::stod(rows[0]["fraction_skewness_over_0.8"]) < 0.01);
    CHECK_THAT(slurp(fs::path(dir) / "out/cohort-summary.json"), Catch::Contains("\"tets\": "));
}

TEST_CASE("cohort: -j 2 gives the rows of -j 1", "[pipeline]") {
    const std::string dir = cohort_dir("cohort_jobs");
    write_file(dir + "/manifest.csv", kManifest);
    // The surface stages are enough to compare the two schedules (--until reaches every subject).
    CHECK(run_frontmesh("cohort manifest.csv --recipe recipe.yaml --quiet -j 1 --until repair "
                        "--set output.dir=one",
                        dir)
              .exit_code == 1);
    CHECK(run_frontmesh("cohort manifest.csv --recipe recipe.yaml --quiet -j2 --until repair --set "
                        "output.dir=two",
                        dir)
              .exit_code == 1);
    CHECK_FALSE(fs::exists(fs::path(dir) / "one/sub-01/checkpoints/04-tetra.vtu"));
    CHECK(run_frontmesh("cohort manifest.csv --recipe recipe.yaml --quiet --until nowhere", dir)
              .exit_code == 2);
    auto one = summary_rows(fs::path(dir) / "one/cohort-summary.csv");
    auto two = summary_rows(fs::path(dir) / "two/cohort-summary.csv");
    REQUIRE(one.size() == 3);
    for (auto* rows : {&one, &two})
        for (auto& row : *rows) {
            // Times of the run and the folder it wrote into differ by nature.
            for (const char* column : {"wall_s", "total_wall_s", "started", "finished", "summary"})
                row.erase(column);
        }
    CHECK(one == two);
    // The subjects' checkpoints are byte for byte the same too.
    CHECK(slurp(fs::path(dir) / "one/sub-02/checkpoints/02-repair.vtu") ==
          slurp(fs::path(dir) / "two/sub-02/checkpoints/02-repair.vtu"));
}

TEST_CASE("cohort: a bad manifest or recipe exits 2 with one line and writes nothing",
          "[pipeline]") {
    const std::string dir = cohort_dir("cohort_bad");
    auto expect_clean_failure = [&](const std::string& manifest, const std::string& args,
                                    const std::string& needle) {
        write_file(dir + "/bad.csv", manifest);
        const auto r = run_frontmesh("cohort bad.csv --recipe recipe.yaml " + args, dir);
        INFO(manifest << args << "\n" << r.err);
        CHECK(r.exit_code == 2);
        CHECK_THAT(r.err, Catch::Contains(needle));
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
        CHECK_FALSE(fs::exists(fs::path(dir) / "out"));
    };
    expect_clean_failure("id,file\nsub-01,small.mha\n", "", "bad.csv:1: no 'image' column");
    expect_clean_failure("id,image\nsub-01,small.mha\nsub-01,large.mha\n", "",
                         "bad.csv:3: id 'sub-01' is also on line 2");
    expect_clean_failure(
        "id,image,input.threshhold\nsub-01,small.mha,\n", "",
        "bad.csv:1: column input.threshhold: unknown key; did you mean 'input.threshold'?");
    expect_clean_failure(
        "id,image,extract.smoothing_iterations\nsub-01,small.mha,4\nsub-02,large.mha,many\n", "",
        "bad.csv:3: subject 'sub-02': extract.smoothing_iterations: expected a whole number, got "
        "'many'");
    expect_clean_failure("id,image\nsub/01,small.mha\n", "", "cannot be a folder name");
    // A missing image is the subject's failure, but a bad value beside it is still the manifest's.
    expect_clean_failure("id,image,extract.blur_sigma_mm\nsub-01,gone.mha,-1\n", "",
                         "subject 'sub-01': extract.blur_sigma_mm");
    expect_clean_failure("id,image\nsub-01,small.mha\n", "--set extract.methd=auto",
                         "did you mean 'extract.method'");
    expect_clean_failure("id,image\nsub-01,small.mha\n", "-j 0", "-j 0");
    expect_clean_failure("id,image\nsub-01,small.mha\n", "--from repair", "--from");
    write_file(dir + "/typo.yaml", "output:\n  dri: out\n");
    expect_clean_failure("id,image\nsub-01,small.mha\n", "--recipe typo.yaml",
                         "did you mean 'output.dir'");
    const auto no_recipe = run_frontmesh("cohort bad.csv", dir);
    CHECK(no_recipe.exit_code == 2);
    CHECK_THAT(no_recipe.err, Catch::Contains("--recipe"));
    CHECK(run_frontmesh("cohort nothere.csv --recipe recipe.yaml", dir).exit_code == 2);
    CHECK(run_frontmesh("run recipe.yaml -j 2", dir).exit_code == 2);
    CHECK_FALSE(fs::exists(fs::path(dir) / "out"));
}

TEST_CASE("cohort: a crashing subject is recorded and cannot take the others down", "[pipeline]") {
    const std::string dir = cohort_dir("cohort_signal");
    // A stand-in executable: kills itself for subject sub-segv, runs frontmesh for the others.
    write_file(dir + "/fake-frontmesh.sh",
               "#!/bin/sh\ncase \"$*\" in *sub-segv*) ulimit -c 0; kill -SEGV $$ ;; esac\nexec '" +
                   std::string(FRONTMESH_BINARY) + "' \"$@\"\n");
    fs::permissions(dir + "/fake-frontmesh.sh", fs::perms::owner_all);
    write_file(dir + "/manifest.csv",
               "id,image\nfirst,small.mha\nsub-segv,large.mha\nlast,large.mha\n");
    std::vector<std::string> progress;
    pipeline::CohortOptions options;
    options.recipe = dir + "/recipe.yaml";
    options.overrides = {"output.dir=" + dir + "/out"};
    options.jobs = 2;
    options.until = "repair";
    options.executable = dir + "/fake-frontmesh.sh";
    options.on_progress = [&](const std::string& line) { progress.push_back(line); };
    const auto result = pipeline::run_cohort(dir + "/manifest.csv", options);
    REQUIRE(result.subjects.size() == 3);
    CHECK(result.root == dir + "/out");
    CHECK(result.subjects[0].status == pipeline::SubjectStatus::Ok);
    CHECK(result.subjects[1].status == pipeline::SubjectStatus::Failed);
    CHECK(result.subjects[1].exit_code == 128 + 11);
    CHECK_THAT(result.subjects[1].error, Catch::Contains("killed by signal 11"));
    CHECK(result.subjects[2].status == pipeline::SubjectStatus::Ok);
    CHECK(result.count(pipeline::SubjectStatus::Failed) == 1);
    REQUIRE(progress.size() == 3);
    CHECK_THAT(progress.back(), Catch::StartsWith("[3/3] "));

    SECTION("an executable that cannot start fails every subject, cleanly") {
        options.executable = dir + "/no-such-frontmesh";
        options.on_progress = nullptr;
        const auto none = pipeline::run_cohort(dir + "/manifest.csv", options);
        CHECK(none.count(pipeline::SubjectStatus::Failed) == 3);
        CHECK_THAT(none.subjects[0].error, Catch::Contains("cannot start"));
        CHECK_THAT(slurp(dir + "/out/cohort-summary.json"), Catch::Contains("\"failed\": 3"));
    }
}

TEST_CASE("cohort Snakefile runs two subjects locally with snakemake -j 2",
          "[pipeline][asan-slow][e2e]") {
    if (std::system("command -v snakemake > /dev/null 2>&1") != 0) {
        WARN("snakemake is not on PATH (apt-get install snakemake); Snakefile test skipped");
        return;
    }
    const std::string dir = cohort_dir("cohort_snakemake");
    write_file(dir + "/manifest.csv",
               "id,image,extract.smoothing_iterations\nsmall,small.mha,\nlarge,large.mha,4\n");
    write_file(dir + "/config.yaml", "manifest: " + dir + "/manifest.csv\nrecipe: " + dir +
                                         "/recipe.yaml\noutdir: " + dir + "/smk-out\nfrontmesh: " +
                                         FRONTMESH_BINARY + "\nthreads: 1\nuntil: repair\n");
    const std::string command =
        "cd '" + dir + "' && snakemake -s '" + FRONTMESH_SOURCE_DIR +
        "/examples/cohort/Snakefile' -j 2 --configfile config.yaml > snakemake.txt 2>&1";
    const int status = std::system(command.c_str());
    INFO(slurp(dir + "/snakemake.txt"));
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 0);
    for (const char* id : {"small", "large"})
        CHECK_THAT(slurp(dir + "/smk-out/" + id + "/summary.json"),
                   Catch::Contains("\"status\": \"ok\""));
    const auto rows = summary_rows(dir + "/smk-out/cohort-summary.csv");
    REQUIRE(rows.size() == 2);
    CHECK(rows[0].at("id") == "small");
    CHECK(rows[1].at("id") == "large");
    CHECK(rows[1].at("status") == "ok");
    CHECK(std::stod(rows[1].at("faces")) > std::stod(rows[0].at("faces")));
    // The same columns as frontmesh cohort's (issue 22).
    CHECK(rows[0].at("image_spacing_mm") == "1;1;1");
    CHECK(!rows[0].at("started").empty());
    CHECK(rows[0].at("summary") == dir + "/smk-out/small/summary.json");
    CHECK(rows[0].at("recipe") == dir + "/recipe.yaml");
    CHECK_THAT(rows[0].at("outputs"), Catch::Contains("surface.vtu"));
    CHECK_FALSE(fs::exists(dir + "/smk-out/small/checkpoints/04-tetra.vtu"));  // until: repair

    SECTION("the SLURM profile submits each subject through sbatch with its resources") {
        // A stand-in sbatch: records its options, runs the job script at once, prints a job id.
        fs::create_directories(dir + "/fakebin");
        write_file(
            dir + "/fakebin/sbatch",
            "#!/bin/sh\necho \"$@\" >> \"$(dirname \"$0\")/calls.txt\"\nfor script; do :; done\n"
            "sh \"$script\" > \"$(dirname \"$0\")/job-$$.out\" 2>&1\necho $$\n");
        fs::permissions(dir + "/fakebin/sbatch", fs::perms::owner_all);
        write_file(dir + "/slurm.yaml", "manifest: " + dir + "/manifest.csv\nrecipe: " + dir +
                                            "/recipe.yaml\noutdir: " + dir +
                                            "/slurm-out\nfrontmesh: " + FRONTMESH_BINARY +
                                            "\nthreads: 1\nuntil: repair\n");
        const std::string slurm =
            "cd '" + dir + "' && PATH='" + dir + "/fakebin':\"$PATH\" snakemake -s '" +
            FRONTMESH_SOURCE_DIR + "/examples/cohort/Snakefile' --profile '" +
            FRONTMESH_SOURCE_DIR +
            "/examples/cohort/profiles/slurm' --configfile slurm.yaml > slurm.txt 2>&1";
        const int slurm_status = std::system(slurm.c_str());
        INFO(slurp(dir + "/slurm.txt"));
        CHECK(WEXITSTATUS(slurm_status) == 0);
        const std::string calls = slurp(dir + "/fakebin/calls.txt");
        CHECK_THAT(calls, Catch::Contains("--job-name=frontmesh-subject-small") &&
                              Catch::Contains("--job-name=frontmesh-subject-large") &&
                              Catch::Contains("--cpus-per-task=1 --mem=4000 --time=60"));
        CHECK(summary_rows(dir + "/slurm-out/cohort-summary.csv").size() == 2);
    }
}
