// Bad output folders and recipe files: exit 2, one line naming the place, nothing written.
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>

#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/skip.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
using frontmesh::testing::write_file;
namespace fs = std::filesystem;

namespace {

std::string phantom_dir(const std::string& name) {
    const std::string dir = fixtures::temp_dir(name);
    fixtures::write_metaimage(fixtures::sphere_image(8, 2.0), dir + "/ball.mha");
    write_file(dir + "/recipe.yaml", "input:\n  image: ball.mha\noutput:\n  dir: out\n");
    return dir;
}

std::size_t entries_below(const fs::path& dir) {
    std::size_t n = 0;
    for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator();
         ++it)
        ++n;
    return n;
}

// `frontmesh COMMAND recipe.yaml ARGS` fails with exit 2 and one line holding `needle`,
// and the test folder gains nothing. Labels [9] are not in the image: a run that got past
// the folder check would stop on them before writing anything.
void expect_refused(const std::string& dir, const std::string& command, const std::string& args,
                    const std::string& needle) {
    const std::size_t before = entries_below(dir);
    const auto r =
        run_frontmesh(command + " recipe.yaml --quiet --set input.labels=[9] " + args, dir);
    INFO(command << " " << args << "\n" << r.err);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains(needle));
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK(entries_below(dir) == before);
}

void expect_refused_both(const std::string& dir, const std::string& args,
                         const std::string& needle) {
    expect_refused(dir, "run", args, needle);
    expect_refused(dir, "validate", args, needle);
}

}  // namespace

TEST_CASE("an output.dir that cannot hold a run is refused before any work", "[pipeline]") {
    const std::string dir = phantom_dir("outdir_bad");
    write_file(dir + "/afile", "x");
    SECTION("a file") {
        expect_refused_both(dir, "--set output.dir=afile", "is a file, not a folder");
    }
    SECTION("under a file") {
        expect_refused_both(dir, "--set output.dir=afile/out", "/afile' is a file");
    }
    SECTION("on a pseudo filesystem") {
        expect_refused_both(dir, "--set output.dir=/proc/frontmesh-out", "pseudo filesystem /proc");
        expect_refused_both(dir, "--set output.dir=/sys/x", "pseudo filesystem /sys");
    }
    SECTION("a name longer than NAME_MAX") {
        expect_refused_both(dir, "--set output.dir=" + std::string(300, 'a'),
                            "has a name of 300 characters");
    }
    SECTION("checkpoints is a file") {
        fs::create_directories(dir + "/used");
        write_file(dir + "/used/.frontmesh-output", "frontmesh\n");
        write_file(dir + "/used/checkpoints", "x");
        expect_refused_both(dir, "--set output.dir=used", "checkpoints' is a file, not a folder");
    }
}

TEST_CASE("an output.dir below a folder it may not write is refused", "[pipeline]") {
    if (getuid() == 0) FM_SKIP("root may write into any folder");
    const std::string dir = phantom_dir("outdir_locked");
    fs::create_directories(dir + "/locked");
    fs::permissions(dir + "/locked", fs::perms::owner_read | fs::perms::owner_exec);
    expect_refused_both(dir, "--set output.dir=locked/out", "is not writable");
    fs::permissions(dir + "/locked", fs::perms::owner_all);
}

TEST_CASE("the root, system folders, home and the input's folder are refused", "[pipeline]") {
    const std::string dir = phantom_dir("outdir_refused");
    expect_refused_both(dir, "--set output.dir=/", "is the filesystem root");
    for (const char* system : {"/etc", "/usr", "/root", "/bin", "/lib", "/var"})
        expect_refused_both(dir, std::string("--set output.dir=") + system, "is a system folder");
    expect_refused_both(dir, "--set output.dir=.", "holds the input '");
    expect_refused_both(dir, "--set output.dir=..", "holds the input '");
    // Allowed on request: validate accepts the folder holding the image.
    const auto allowed = run_frontmesh(
        "validate recipe.yaml --set output.dir=. --set output.allow_input_folder=true", dir);
    INFO(allowed.err);
    CHECK(allowed.exit_code == 0);
}

TEST_CASE("a non-empty folder frontmesh did not make is refused, its own reused", "[pipeline]") {
    const std::string dir = phantom_dir("outdir_marker");
    fs::create_directories(dir + "/foreign");
    write_file(dir + "/foreign/thesis.tex", "mine");
    expect_refused_both(dir, "--set output.dir=foreign", "is not a frontmesh output folder");
    fs::create_directories(dir + "/empty");
    CHECK(run_frontmesh("validate recipe.yaml --set output.dir=empty", dir).exit_code == 0);

    const auto first = run_frontmesh("run recipe.yaml --quiet --until extract", dir);
    INFO(first.err);
    REQUIRE(first.exit_code == 0);
    CHECK_THAT(testing::slurp(dir + "/out/.frontmesh-output"), Catch::StartsWith("frontmesh "));
    CHECK(run_frontmesh("run recipe.yaml --quiet --until extract --force", dir).exit_code == 0);
}

TEST_CASE("a recipe with a key twice, or that is not a readable file, is bad input", "[pipeline]") {
    const std::string dir = phantom_dir("outdir_recipe");
    auto expect_bad = [&](const std::string& args, const std::string& needle) {
        for (const char* command : {"run", "validate"}) {
            const auto r = run_frontmesh(std::string(command) + " " + args + " --quiet", dir);
            INFO(command << " " << args << "\n" << r.err);
            CHECK(r.exit_code == 2);
            CHECK_THAT(r.err, Catch::Contains(needle));
            CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
            CHECK_FALSE(fs::exists(dir + "/out"));
        }
    };
    write_file(dir + "/twice.yaml", "input:\n  image: ball.mha\n  image: other.mha\n");
    expect_bad("twice.yaml", "twice.yaml:3: input.image: given twice (first on line 2)");
    write_file(dir + "/sections.yaml", "input:\n  image: ball.mha\ninput:\n  labels: all\n");
    expect_bad("sections.yaml", "sections.yaml:3: input: given twice");
    fs::create_directories(dir + "/folder.yaml");
    expect_bad("folder.yaml", "folder.yaml' is a folder");
    REQUIRE(mkfifo((dir + "/pipe.yaml").c_str(), 0600) == 0);
    expect_bad("pipe.yaml", "pipe.yaml' is a named pipe, not a regular file");
}

TEST_CASE("cohort checks its output folder as run does", "[pipeline]") {
    const std::string dir = phantom_dir("outdir_cohort");
    write_file(dir + "/subjects.csv", "id,image\na,ball.mha\n");
    fs::create_directories(dir + "/foreign");
    write_file(dir + "/foreign/notes.txt", "mine");
    for (const auto& [root, needle] :
         {std::pair<std::string, std::string>{"/etc", "'/etc' is a system folder"},
          {"foreign", "is not a frontmesh output folder"},
          {"/proc/x", "pseudo filesystem /proc"}}) {
        const std::size_t before = entries_below(dir);
        const auto r = run_frontmesh(
            "cohort subjects.csv --recipe recipe.yaml --quiet --set output.dir=" + root, dir);
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK_THAT(r.err, Catch::Contains("output.dir") && Catch::Contains(needle));
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
        CHECK(entries_below(dir) == before);
    }
}

TEST_CASE("a path over PATH_MAX, or a result name taken by a folder or pipe, is refused",
          "[pipeline]") {
    const std::string dir = phantom_dir("outdir_names");
    SECTION("a path longer than PATH_MAX") {
        std::string deep;
        for (int i = 0; i < 20; ++i) deep += std::string(250, 'd') + "/";
        expect_refused_both(dir, "--set output.dir=" + deep, "characters long; at most");
    }
    fs::create_directories(dir + "/used/checkpoints");
    write_file(dir + "/used/.frontmesh-output", "frontmesh\n");
    SECTION("summary.json is a folder") {
        fs::create_directories(dir + "/used/summary.json");
        expect_refused_both(dir, "--set output.dir=used", "summary.json' is a folder, not a file");
    }
    SECTION("an export's name is a folder") {
        fs::create_directories(dir + "/used/mesh.inp");
        expect_refused_both(dir, "--set output.dir=used --set output.formats=[vtu,inp]",
                            "mesh.inp' is a folder, not a file");
    }
    SECTION("frontmesh.log is a named pipe (opening it would block)") {
        REQUIRE(mkfifo((dir + "/used/frontmesh.log").c_str(), 0600) == 0);
        expect_refused_both(dir, "--set output.dir=used", "frontmesh.log' is a named pipe");
    }
    SECTION("a named pipe among the checkpoints") {
        REQUIRE(mkfifo((dir + "/used/checkpoints/01-extract.vtu").c_str(), 0600) == 0);
        expect_refused_both(dir, "--set output.dir=used", "01-extract.vtu' is a named pipe");
    }
    // Found by the malformed-input campaign (issue 21): the log was appended to the file a
    // link named, the checkpoints written into the folder a link named, and a link to a
    // missing folder as output.dir was an internal error.
    fs::create_directories(dir + "/outside");
    write_file(dir + "/outside/precious.txt", "mine\n");
    SECTION("frontmesh.log is a link out of the folder") {
        fs::create_symlink("../outside/precious.txt", dir + "/used/frontmesh.log");
        expect_refused_both(dir, "--set output.dir=used", "frontmesh.log' is a symbolic link");
    }
    SECTION("checkpoints is a link out of the folder") {
        fs::remove_all(dir + "/used/checkpoints");
        fs::create_symlink("../outside", dir + "/used/checkpoints");
        expect_refused_both(dir, "--set output.dir=used", "checkpoints' is a symbolic link");
    }
    SECTION("a checkpoint is a link") {
        fs::create_symlink("../../outside/precious.txt", dir + "/used/checkpoints/02-repair.vtu");
        expect_refused_both(dir, "--set output.dir=used", "02-repair.vtu' is a symbolic link");
    }
    SECTION("output.dir is a link to a folder that does not exist") {
        fs::create_symlink("gone/deeper", dir + "/dangling");
        expect_refused_both(dir, "--set output.dir=dangling",
                            "is a symbolic link to 'gone/deeper', which does not exist");
    }
    SECTION("output.dir is a link to a folder: it is used") {
        fs::create_directories(dir + "/real");
        fs::create_symlink("real", dir + "/linked");
        const auto r = run_frontmesh("validate recipe.yaml --quiet --set output.dir=linked", dir);
        INFO(r.err);
        CHECK(r.exit_code == 0);
    }
    CHECK(fs::file_size(dir + "/outside/precious.txt") == 5);
}

TEST_CASE("a named pipe or folder given as an input is refused without opening it", "[pipeline]") {
    const std::string dir = phantom_dir("outdir_pipes");
    REQUIRE(mkfifo((dir + "/pipe.mha").c_str(), 0600) == 0);
    REQUIRE(mkfifo((dir + "/pipe.stl").c_str(), 0600) == 0);
    REQUIRE(mkfifo((dir + "/pipe.txt").c_str(), 0600) == 0);
    REQUIRE(mkfifo((dir + "/pipe.csv").c_str(), 0600) == 0);
    REQUIRE(mkfifo((dir + "/pipe.vtu").c_str(), 0600) == 0);
    fs::create_directories(dir + "/folder.stl");
    // A reader that opened a pipe would wait for a writer forever: each of these would hang.
    expect_refused_both(dir, "--set input.image=pipe.mha", "pipe.mha' is a named pipe");
    expect_refused_both(dir, "--set input.label_names=pipe.txt", "pipe.txt' is a named pipe");
    write_file(dir + "/pipe.yaml", "input:\n  surface: pipe.stl\noutput:\n  dir: out\n");
    write_file(dir + "/folder.yaml", "input:\n  surface: folder.stl\noutput:\n  dir: out\n");
    for (const auto& [command, needle] : std::vector<std::pair<std::string, std::string>>{
             {"run pipe.yaml", "pipe.yaml:2: input.surface: '"},
             {"validate pipe.yaml", "pipe.stl' is a named pipe, not a regular file"},
             {"run folder.yaml", "folder.stl' is a folder; give a file"},
             {"cohort pipe.csv --recipe recipe.yaml", "pipe.csv' is a named pipe"},
             {"check pipe.vtu", "pipe.vtu' is a named pipe"},
             {"convert pipe.vtu x.msh", "pipe.vtu' is a named pipe"}}) {
        const std::size_t before = entries_below(dir);
        const auto r = run_frontmesh(command + " --quiet", dir);
        INFO(command << "\n" << r.err);
        CHECK(r.exit_code == 2);
        CHECK_THAT(r.err, Catch::Contains(needle));
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
        CHECK(entries_below(dir) == before);
    }
}

TEST_CASE("a key given twice in a --set value or as two spellings of a label is refused",
          "[pipeline]") {
    const std::string dir = phantom_dir("outdir_twice");
    expect_refused_both(dir, "--set 'remesh.label_edge_length={1: 0.5, 1: 0.7}'",
                        "--set remesh.label_edge_length.1: given twice");
    write_file(dir + "/labels.yaml",
               "input:\n  image: ball.mha\nremesh:\n  label_edge_length: {1: 0.5, 01: 0.7}\n");
    const auto r = run_frontmesh("validate labels.yaml", dir);
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains("labels.yaml:4: remesh.label_edge_length: label 1 is "
                                      "given twice"));
}

TEST_CASE("validate checks an image's labels and the work they ask for, as a run does",
          "[pipeline]") {
    // The malformed-input campaign (issue 21): validate said "valid" to a label the run then
    // refused.
    const std::string dir = phantom_dir("validate_image");
    auto r = run_frontmesh("validate recipe.yaml --set input.labels=[1]", dir);
    CHECK(r.exit_code == 0);
    r = run_frontmesh("validate recipe.yaml --set input.labels=[7]", dir);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err,
               Catch::Contains("input.labels: label 7 is not in") && Catch::Contains("ball.mha"));
    r = run_frontmesh("validate recipe.yaml --set remesh.edge_length=0.000001", dir);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains("limits.max_memory_gib"));
    // --until repair: no remesh, so no estimate.
    r = run_frontmesh("validate recipe.yaml --set remesh.edge_length=0.000001 --until repair", dir);
    CHECK(r.exit_code == 0);
    CHECK_FALSE(fs::exists(fs::path(dir) / "out"));
}

TEST_CASE("an error is one line whatever it quotes, and a flag's empty value is refused",
          "[pipeline]") {
    // Campaign seed 4 (issue 21): an unknown command "run\n" printed two lines, and
    // `--until ''` ran every stage as if no --until were given.
    const std::string dir = phantom_dir("one_line");
    auto r = run_frontmesh("'run\n' recipe.yaml", dir);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::StartsWith("frontmesh: error: run\\n: unknown command"));
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    r = run_frontmesh("run recipe.yaml --until ''", dir);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains("--until: an empty value"));
    CHECK_FALSE(fs::exists(fs::path(dir) / "out"));
}
