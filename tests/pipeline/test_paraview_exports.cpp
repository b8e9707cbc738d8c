// Result files of a run for viewers (issue 22): mesh_surface.vtp beside mesh.vtu, and
// output.binary for mesh.msh, which a re-run with another setting writes again.

#include <filesystem>
#include <string>

#include <catch2/catch.hpp>

#include "io/export.h"
#include "tests/fixtures/phantoms.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
using frontmesh::testing::slurp;
using frontmesh::testing::write_file;
namespace fs = std::filesystem;

TEST_CASE("a run writes mesh_surface.vtp and, with output.binary, a binary mesh.msh",
          "[pipeline][export]") {
    const std::string dir = fixtures::temp_dir("paraview_exports");
    fixtures::write_metaimage(fixtures::sphere_image(16, 5.0), dir + "/ball.mha");
    auto recipe = [](bool binary) {
        return std::string("input:\n  image: ball.mha\noutput:\n  dir: out\n") +
               "  formats: [vtu, msh]\n  binary: " + (binary ? "true" : "false") + "\n";
    };
    write_file(dir + "/r.yaml", recipe(true));
    auto r = run_frontmesh("run r.yaml --quiet", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const fs::path out = fs::path(dir) / "out";
    CHECK_THAT(slurp(out / "mesh.msh"), Catch::StartsWith("$MeshFormat\n4.1 1 8\n"));
    REQUIRE(fs::exists(out / "mesh_surface.vtp"));
    CHECK_THAT(slurp(out / "mesh_surface.vtp"), Catch::Contains("Name=\"tag\""));
    CHECK_THAT(slurp(out / "checkpoints" / "results.hash"), Catch::Contains("mesh_surface.vtp "));
    const core::TetMesh vtu = io::read_mesh((out / "mesh.vtu").string());
    CHECK_THAT(slurp(out / "mesh.vtu"), Catch::Contains("Name=\"colour\""));
    const core::TetMesh binary = io::read_mesh((out / "mesh.msh").string());
    CHECK(binary.xyz == vtu.xyz);
    CHECK(binary.tets == vtu.tets);
    r = run_frontmesh("check out/mesh.msh", dir);
    CHECK(r.exit_code == 0);

    // Only the setting changed: mesh.msh is written again, as text.
    write_file(dir + "/r.yaml", recipe(false));
    r = run_frontmesh("run r.yaml --quiet", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(slurp(out / "mesh.msh"), Catch::StartsWith("$MeshFormat\n4.1 0 8\n"));
    const core::TetMesh msh = io::read_mesh((out / "mesh.msh").string());
    CHECK(msh.xyz == vtu.xyz);
    CHECK(msh.tets == vtu.tets);
    CHECK(msh.region == vtu.region);
}
