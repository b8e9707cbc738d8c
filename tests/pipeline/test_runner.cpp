// The runner's stage context: cancellation (Ctrl-C, SIGTERM, a caller's flag) and the
// diagnostics sink.

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <tbb/parallel_for.h>
#include <catch2/catch.hpp>

#include "io/mesh_io.h"
#include "pipeline/core/error.h"
#include "pipeline/core/stage_context.h"
#include "pipeline/diagnostics.h"
#include "pipeline/recipe.h"
#include "pipeline/runner.h"
#include "tests/fixtures/phantoms.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::slurp;
using frontmesh::testing::write_file;
namespace fs = std::filesystem;

namespace {

// A small triangle diagnostic named `name`.
core::Diagnostic triangle(const std::string& name) {
    core::Diagnostic d;
    d.name = name;
    d.what = "one triangle; kind 7";
    d.add_cell({d.add_point(0, 0, 0), d.add_point(1, 0, 0), d.add_point(0, 1, 0)}, 7);
    return d;
}

// A folder with a labelled ball and a recipe meshing it into out/.
std::string ball_run_dir(const std::string& name) {
    const std::string dir = fixtures::temp_dir(name);
    fixtures::write_metaimage(fixtures::sphere_image(16, 5.0), dir + "/ball.mha");
    write_file(dir + "/recipe.yaml", "input:\n  image: ball.mha\noutput:\n  dir: out\n");
    return dir;
}

}  // namespace

TEST_CASE("a cancelled context stops a stage with CancelledError", "[pipeline]") {
    std::atomic<bool> stop{false};
    core::StageContext ctx({}, {}, {}, &stop);
    CHECK_NOTHROW(ctx.check_cancelled());
    stop = true;
    CHECK(ctx.is_cancelled());
    CHECK_THROWS_AS(ctx.check_cancelled(), core::CancelledError);
    CHECK_THROWS_AS(ctx.child().check_cancelled(), core::CancelledError);
    CHECK_FALSE(core::StageContext().is_cancelled());
}

TEST_CASE("run_recipe stops when asked, finished checkpoints kept", "[pipeline]") {
    const std::string dir = ball_run_dir("run_cancel");
    const pipeline::Recipe recipe =
        pipeline::load_recipe(dir + "/recipe.yaml", {"output.dir=" + dir + "/out"});
    std::atomic<bool> stop{false};
    pipeline::RunOptions options;
    options.quiet = true;
    options.until = "extract";
    options.cancel = &stop;
    pipeline::run_recipe(recipe, options);
    const fs::path out = fs::path(dir) / "out";
    const std::string extract = slurp(out / "checkpoints/01-extract.vtu");
    REQUIRE_FALSE(extract.empty());

    stop = true;
    options.until = "repair";
    try {
        pipeline::run_recipe(recipe, options);
        FAIL("no CancelledError");
    } catch (const core::CancelledError& e) {
        CHECK_THAT(e.what(), Catch::StartsWith("interrupted before reading the input"));
    }
    CHECK(slurp(out / "checkpoints/01-extract.vtu") == extract);
    CHECK_FALSE(fs::exists(out / "checkpoints/02-repair.vtu"));
    CHECK_FALSE(fs::exists(out / "checkpoints/02-repair.json"));
    const std::string summary = slurp(out / "summary.json");
    CHECK_THAT(summary, Catch::Contains("\"status\": \"interrupted\"") &&
                            Catch::Contains("\"error\": \"interrupted before reading the input\""));
    for (const auto& e : fs::recursive_directory_iterator(out))
        CHECK(e.path().filename().string().find(".tmp-") == std::string::npos);
}

TEST_CASE("Ctrl-C: one line, exit code 130, summary interrupted", "[pipeline]") {
    // A ball remeshed far finer than its voxels: remesh, tetra and refine take many seconds
    // after the log names the remesh stage, so SIGINT sent then arrives while the run has its
    // handlers installed and work remains (the wait for the log line is bounded).
    const std::string dir = fixtures::temp_dir("run_sigint");
    fixtures::write_metaimage(fixtures::sphere_image(100, 40.0), dir + "/ball.mha");
    write_file(dir + "/recipe.yaml",
               "input:\n  image: ball.mha\noutput:\n  dir: out\nremesh:\n  edge_length: 0.3\n");
    fs::remove_all(dir + "/out");
    const pid_t pid = fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
        if (chdir(dir.c_str()) != 0) _exit(98);
        const int err = open((dir + "/.stderr").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
        dup2(err, STDERR_FILENO);
        execl(FRONTMESH_BINARY, FRONTMESH_BINARY, "run", "recipe.yaml", "--quiet",
              static_cast<char*>(nullptr));
        _exit(99);
    }
    bool in_remesh = false;
    for (int tries = 0; !in_remesh && tries < 6000; ++tries) {
        in_remesh = slurp(dir + "/out/frontmesh.log").find("] remesh") != std::string::npos;
        if (!in_remesh) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    REQUIRE(in_remesh);
    REQUIRE(kill(pid, SIGINT) == 0);
    int status = 0;
    REQUIRE(waitpid(pid, &status, 0) == pid);
    const std::string err = slurp(dir + "/.stderr");
    INFO(err);
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 130);
    CHECK_THAT(err, Catch::StartsWith("frontmesh: interrupted"));
    CHECK(std::count(err.begin(), err.end(), '\n') == 1);
    CHECK_THAT(slurp(dir + "/out/summary.json"), Catch::Contains("\"status\": \"interrupted\""));
    CHECK(fs::exists(dir + "/out/checkpoints/02-repair.vtu"));
    CHECK_FALSE(fs::exists(dir + "/out/checkpoints/03-remesh.vtu"));
    CHECK_FALSE(fs::exists(dir + "/out/mesh.vtu"));
}

TEST_CASE("the diagnostics writer: one file per diagnostic, from any thread", "[pipeline]") {
    const fs::path folder = fs::path(fixtures::temp_dir("diagnostics_writer")) / "diagnostics";
    std::mutex lines_mutex;
    std::vector<std::string> lines;
    pipeline::DiagnosticsWriter writer(folder,
                                       [&](core::LogLevel, const std::string& line) {
                                           const std::lock_guard lock(lines_mutex);
                                           lines.push_back(line);
                                       },
                                       {{"frame", "lps"}});
    writer.start("tetra");
    core::StageContext ctx({}, {}, writer.sink());
    REQUIRE(ctx.wants_diagnostics());
    tbb::parallel_for(
        0, 16, [&](int i) { ctx.child().diagnose(triangle("region " + std::to_string(i % 8))); });
    const auto files = pipeline::DiagnosticsWriter::files_of(folder, "tetra");
    CHECK(files.size() == 16);  // names given twice get -2
    CHECK(lines.size() == 16);
    CHECK(fs::exists(folder / "tetra-region_3.vtu"));
    CHECK(fs::exists(folder / "tetra-region_3-2.vtu"));
    CHECK_THAT(lines.front(),
               Catch::Contains("diagnostic: wrote") && Catch::Contains("one triangle"));
    for (const auto& e : fs::directory_iterator(folder))
        CHECK(e.path().filename().string().find(".tmp-") == std::string::npos);

    // A stage started again forgets its earlier files, not those of other stages.
    writer.start("refine");
    ctx.diagnose(triangle("cavity"));
    writer.start("tetra");
    CHECK(pipeline::DiagnosticsWriter::files_of(folder, "tetra").empty());
    CHECK(pipeline::DiagnosticsWriter::files_of(folder, "refine").size() == 1);
}

TEST_CASE("the diagnostics writer keeps the first files of a run and counts the rest",
          "[pipeline]") {
    // Issue 21: remesh retries on a 16^3 block of random labels wrote 642 files, 38 MB.
    const fs::path folder = fs::path(fixtures::temp_dir("diagnostics_cap")) / "diagnostics";
    std::vector<std::string> lines;
    pipeline::DiagnosticsWriter writer(
        folder, [&](core::LogLevel, const std::string& line) { lines.push_back(line); }, {});
    constexpr int cap = pipeline::DiagnosticsWriter::max_files_per_run;
    writer.start("remesh");
    core::StageContext ctx({}, {}, writer.sink());
    for (int i = 0; i < cap - 5; ++i) ctx.diagnose(triangle("stall"));
    writer.finish();
    CHECK(writer.not_written() == 0);
    writer.start("tetra");  // the cap is per run: 5 files left for this stage
    for (int i = 0; i < 12; ++i) ctx.diagnose(triangle("front"));
    CHECK(writer.not_written() == 7);
    writer.finish();
    CHECK(pipeline::DiagnosticsWriter::files_of(folder, "remesh").size() == cap - 5);
    CHECK(pipeline::DiagnosticsWriter::files_of(folder, "tetra").size() == 5);
    CHECK(fs::exists(folder / "tetra-front-5.vtu"));
    CHECK_FALSE(fs::exists(folder / "tetra-front-6.vtu"));
    REQUIRE_FALSE(lines.empty());
    CHECK_THAT(lines.back(), Catch::Contains("diagnostics: 7 more of tetra not written") &&
                                 Catch::Contains("at most " + std::to_string(cap)));
}

TEST_CASE("summary.json lists the diagnostics of its stages", "[pipeline]") {
    const std::string dir = ball_run_dir("run_diagnostics");
    const auto first = testing::run_frontmesh("run recipe.yaml --quiet --until repair", dir);
    REQUIRE(first.exit_code == 0);
    const fs::path out = fs::path(dir) / "out";
    CHECK_THAT(slurp(out / "summary.json"), Catch::Contains("\"diagnostics\": []"));
    io::write_diagnostic_vtu(triangle("hole"), (out / "diagnostics/repair-hole.vtu").string());

    const auto again = testing::run_frontmesh("run recipe.yaml --quiet --until repair", dir);
    REQUIRE(again.exit_code == 0);
    CHECK_THAT(slurp(out / "summary.json"),
               Catch::Contains("\"diagnostics\": [\"diagnostics/repair-hole.vtu\"]"));

    const auto forced =
        testing::run_frontmesh("run recipe.yaml --quiet --until repair --force", dir);
    REQUIRE(forced.exit_code == 0);
    CHECK_FALSE(fs::exists(out / "diagnostics/repair-hole.vtu"));
    CHECK_THAT(slurp(out / "summary.json"), Catch::Contains("\"diagnostics\": []"));
}

namespace {

// The files a run leaves that must not depend on timing (the log, the summaries and the
// stages' .json hold wall times), by path below `dir`, with their bytes; report.html
// without its table of the stages' timings.
std::map<std::string, std::string> result_files(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
        const std::string name = fs::relative(entry.path(), dir).string();
        if (entry.is_regular_file() && entry.path().extension() != ".json" &&
            entry.path().extension() != ".log")
            files[name] = slurp(entry.path());
    }
    if (const auto report = files.find("report.html"); report != files.end()) {
        std::string& html = report->second;
        const auto from = html.find("<h2>Stages</h2>");
        if (from != std::string::npos) html.erase(from, html.find("</table>", from) - from);
    }
    return files;
}

// Thrown at a chosen commit: the run ends there, as a kill -9 would end it.
struct SimulatedKill {};

}  // namespace

TEST_CASE("a run stopped between any two commits resumes to the uninterrupted result",
          "[pipeline]") {
    const std::string dir = ball_run_dir("run_commits");
    // P1 and P2 differ in tetra only, so a P2 run over a P1 folder commits tetra, refine
    // and the result files; resuming with P1 is the case of the issue: P1's hashes must
    // not be paired with P2's checkpoints.
    auto run = [&](const fs::path& out, const std::string& stretching,
                   std::function<void(const std::string&)> on_commit = {}) {
        const pipeline::Recipe recipe = pipeline::load_recipe(
            dir + "/recipe.yaml", {"output.dir=" + out.string(), "output.formats=[vtu, inp]",
                                   "tetra.stretching=" + stretching});
        pipeline::RunOptions options;
        options.quiet = true;
        options.on_commit = std::move(on_commit);
        pipeline::run_recipe(recipe, options);
    };
    const fs::path p1 = fs::path(dir) / "p1", p2 = fs::path(dir) / "p2";
    run(p1, "1.15");
    run(p2, "1.3");
    const auto expected_p1 = result_files(p1), expected_p2 = result_files(p2);
    REQUIRE(expected_p1.count("mesh.inp") == 1);
    REQUIRE(expected_p1.count("report.html") == 1);
    REQUIRE(expected_p1.at("checkpoints/04-tetra.vtu") !=
            expected_p2.at("checkpoints/04-tetra.vtu"));

    const fs::path work = fs::path(dir) / "work";
    auto restore_p1 = [&] {
        fs::remove_all(work);
        fs::copy(p1, work, fs::copy_options::recursive);
    };
    restore_p1();
    std::vector<std::string> commits;
    run(work, "1.3", [&](const std::string& path) { commits.push_back(path); });
    CHECK(result_files(work) == expected_p2);
    // remove and write the .hash of tetra and refine around their checkpoints and .json,
    // then the record, mesh.vtu, mesh.inp, report.html and the record again.
    REQUIRE(commits.size() >= 12);

    for (std::size_t k = 0; k < commits.size(); ++k) {
        for (const char* resume : {"1.15", "1.3"}) {
            INFO("stopped after commit " << k << " (" << commits[k] << "), resumed with "
                                         << resume);
            restore_p1();
            std::size_t seen = 0;
            CHECK_THROWS_AS(run(work, "1.3",
                                [&](const std::string&) {
                                    if (seen++ == k) throw SimulatedKill{};
                                }),
                            SimulatedKill);
            run(work, resume);
            CHECK(result_files(work) ==
                  (std::string(resume) == "1.15" ? expected_p1 : expected_p2));
        }
    }
}

TEST_CASE("temporary files of a killed run are removed, those of live writers kept", "[pipeline]") {
    const std::string dir = ball_run_dir("run_stale_temp");
    const pipeline::Recipe recipe =
        pipeline::load_recipe(dir + "/recipe.yaml", {"output.dir=" + dir + "/out"});
    pipeline::RunOptions options;
    options.quiet = true;
    options.until = "extract";
    pipeline::run_recipe(recipe, options);
    // A pid above any pid_max (2^22) names a process that cannot exist.
    const fs::path out = fs::path(dir) / "out";
    const std::vector<fs::path> stale = {out / ".summary.json.tmp-99999999-0",
                                         out / "checkpoints/.02-repair.vtu.tmp-99999999-3"};
    const fs::path live =
        out / ("checkpoints/.02-repair.vtu.tmp-" + std::to_string(getpid()) + "-7");
    const fs::path other = out / "checkpoints/.notes.tmp-x";
    for (const fs::path& file : stale) write_file(file.string(), "partial");
    write_file(live.string(), "being written");
    write_file(other.string(), "not ours");
    pipeline::run_recipe(recipe, options);  // up to date: nothing to compute
    for (const fs::path& file : stale) CHECK_FALSE(fs::exists(file));
    CHECK(fs::exists(live));
    CHECK(fs::exists(other));

    // Only in a folder frontmesh marked as its own.
    fs::remove(out / ".frontmesh-output");
    write_file(stale[0].string(), "partial");
    CHECK_THROWS_AS(pipeline::run_recipe(recipe, options), core::InputError);
    CHECK(fs::exists(stale[0]));
}
