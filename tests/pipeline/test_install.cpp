// Library use: `cmake --install` into a temporary prefix, then examples/consumer configured
// and built against it with find_package(frontmesh), and run.

#include <cstdlib>
#include <filesystem>
#include <string>

#include <catch2/catch.hpp>

#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/skip.h"
#include "tests/pipeline/cli_helpers.h"

namespace fs = std::filesystem;
using frontmesh::testing::slurp;

namespace {
// The sanitizer build (scripts/sanitize.sh): its libraries need the sanitizer runtimes and
// clang, which a consumer configured with the system's default compiler does not link.
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

int shell(const std::string& command, const std::string& log) {
    const int status = std::system((command + " > '" + log + "' 2>&1").c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
}  // namespace

TEST_CASE("the installed CMake package builds and runs examples/consumer",
          "[pipeline][asan-slow][install]") {
    if (kSanitized)
        FM_SKIP("a sanitizer build: the installed package is tested in the normal build");
    const fs::path build =
        fs::path(FRONTMESH_TEST_TMP).parent_path().parent_path();  // BUILD/tests/tmp
    REQUIRE(fs::exists(build / "CMakeCache.txt"));
    const std::string dir = frontmesh::fixtures::temp_dir("install");
    const std::string prefix = dir + "/prefix", log = dir + "/log.txt";

    INFO("cmake --install");
    REQUIRE(shell("cmake --install '" + build.string() + "' --prefix '" + prefix + "'", log) == 0);
    CHECK(fs::exists(prefix + "/include/frontmesh/pipeline/runner.h"));
    CHECK(fs::exists(prefix + "/include/frontmesh/pipeline/core/tet_mesh.h"));
    CHECK(fs::exists(prefix + "/lib/cmake/frontmesh/frontmeshConfig.cmake"));
    CHECK(fs::exists(prefix + "/bin/frontmesh"));

    const std::string consumer = dir + "/consumer";
    const std::string configure =
        "cmake -S '" + std::string(FRONTMESH_SOURCE_DIR) + "/examples/consumer' -B '" + consumer +
        "' -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH='" + prefix + "'";
    const int configured = shell(configure, log);
    INFO(slurp(log));
    REQUIRE(configured == 0);
    const int built = shell("cmake --build '" + consumer + "' -j2", log);
    INFO(slurp(log));
    REQUIRE(built == 0);

    // Run a stage in memory and a recipe (extract only) on a phantom.
    frontmesh::fixtures::write_metaimage(frontmesh::fixtures::sphere_image(20, 6.0),
                                         dir + "/ball.mha");
    frontmesh::testing::write_file(dir + "/recipe.yaml", "input:\n  image: ball.mha\n");
    const int ran = shell(
        "'" + consumer + "/frontmesh_consumer' '" + dir + "/recipe.yaml' '" + dir + "/out' extract",
        log);
    const std::string out = slurp(log);
    INFO(out);
    REQUIRE(ran == 0);
    CHECK_THAT(out, Catch::Contains("extract: "));
    CHECK_THAT(out, Catch::Contains("run: "));
    CHECK(fs::exists(dir + "/out/summary.json"));
    CHECK(fs::exists(dir + "/out/checkpoints/01-extract.vtu"));
}
