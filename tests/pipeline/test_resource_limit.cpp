// Runaway work is refused before it starts (issue 21, item 8): remesh and tetra are
// estimated (triangles from area / h^2, tets from volume / h^3, memory from measured bytes
// per element) and compared with limits.max_memory_gib.

#include <cmath>
#include <filesystem>
#include <numbers>

#include <catch2/catch.hpp>

#include "io/mesh_io.h"
#include "pipeline/core/error.h"
#include "pipeline/resource_estimate.h"
#include "tests/fixtures/phantoms.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
using frontmesh::testing::write_file;
namespace fs = std::filesystem;

namespace {

constexpr double kPi = std::numbers::pi;
// Triangles of edge h covering a sphere of radius r.
double sphere_triangles(double r, double h) {
    return 4.0 * kPi * r * r / (std::sqrt(3.0) / 4.0 * h * h);
}

}  // namespace

TEST_CASE("remesh estimate: area / h^2 with per label sizes from a surface or an image",
          "[pipeline][resources]") {
    const core::SurfaceNetwork sphere = fixtures::uv_sphere(10.0, 48);
    surface::RemeshParams params;
    params.edge_length = 1.0;
    const pipeline::ResourceEstimate e = pipeline::remesh_estimate(sphere, params);
    CHECK(e.stage == "remesh");
    CHECK(e.h_mm == 1.0);
    CHECK(e.count == Approx(sphere_triangles(10.0, 1.0)).epsilon(0.02));
    CHECK(e.memory_gib == Approx(e.count * pipeline::remesh_bytes_per_triangle / 1073741824.0));
    // A smaller size for the sphere's label: four times the triangles at half the size.
    params.label_edge_length[1] = 0.5;
    CHECK(pipeline::remesh_estimate(sphere, params).count == Approx(4.0 * e.count));
    // From the voxels: a staircase's area over 1.5 is the smooth sphere's, within 10%.
    params.label_edge_length.clear();
    const core::LabelImage image = fixtures::sphere_image(45, 15.0);
    const pipeline::ResourceEstimate from_voxels = pipeline::remesh_estimate(image, {}, params);
    CHECK(from_voxels.count == Approx(sphere_triangles(15.0, 1.0)).epsilon(0.1));
    CHECK(from_voxels.slack == 2.0);
    CHECK(e.slack == 1.0);
    // Labels not chosen count as outside: nothing of label 2 to mesh.
    CHECK(pipeline::remesh_estimate(image, {2}, params).count == 0.0);
    // h = 0: the stage's own default (twice the background's mean edge length).
    params.edge_length = 0.0;
    CHECK(pipeline::remesh_estimate(sphere, params).h_mm ==
          Approx(surface::default_edge_length(sphere)));
}

TEST_CASE("tetra estimate: the fewer of a uniform and a layered fill", "[pipeline][resources]") {
    volume::TetraParams params;
    // Thin: volume / h^3 is the smaller one.
    const auto thin = pipeline::tetra_estimate(10.0, 1000.0, 1.0, params);
    CHECK(thin.count == Approx(pipeline::tets_per_h3 * 10.0));
    // Thick: the front grows by alpha per level, so the surface's triangles bound it.
    const auto thick = pipeline::tetra_estimate(1e6, 1000.0, 1.0, params);
    CHECK(thick.count == Approx(pipeline::tets_per_layer * 1000.0 / (1.0 - 1.0 / (1.15 * 1.15))));
    params.stretching = 1.05;  // slower growth: more levels, more tets
    CHECK(pipeline::tetra_estimate(1e6, 1000.0, 1.0, params).count > thick.count);
    // From a surface: its enclosed volume and faces.
    const core::SurfaceNetwork sphere = fixtures::uv_sphere(10.0, 24);
    const auto e = pipeline::tetra_estimate(sphere, volume::TetraParams{});
    CHECK(e.stage == "tetra");
    CHECK(e.count > 0.0);
    CHECK(pipeline::enclosed_volume(sphere) == Approx(4.0 / 3.0 * kPi * 1000.0).epsilon(0.05));
}

TEST_CASE("an estimate beyond limits.max_memory_gib is refused naming stage and keys",
          "[pipeline][resources]") {
    const pipeline::ResourceEstimate e{"remesh", "triangles", 2e10, 0.001, 27.9, "area 1 mm^2"};
    CHECK_NOTHROW(pipeline::require_within_memory_limit(e, 32.0));
    CHECK_THROWS_AS(pipeline::require_within_memory_limit(e, 16.0), core::InputError);
    CHECK_THROWS_WITH(pipeline::require_within_memory_limit(e, 16.0),
                      Catch::Contains("remesh: expected about 2e+10 triangles (area 1 mm^2)") &&
                          Catch::Contains("27.9 GiB") &&
                          Catch::Contains("limits.max_memory_gib = 16 GiB") &&
                          Catch::Contains("remesh.edge_length"));
    // An estimate from voxels overstates a folded surface: refused only beyond its slack.
    pipeline::ResourceEstimate from_voxels = e;
    from_voxels.slack = 2.0;
    CHECK_NOTHROW(pipeline::require_within_memory_limit(from_voxels, 16.0));
    CHECK_THROWS_AS(pipeline::require_within_memory_limit(from_voxels, 13.0), core::InputError);
}

TEST_CASE("a tiny remesh.edge_length is refused at once by run and validate",
          "[pipeline][resources]") {
    const std::string dir = fixtures::temp_dir("resource_limit_cli");
    io::write_surface_vtu(fixtures::uv_sphere(10.0, 24), dir + "/sphere.vtu", {});
    fixtures::write_metaimage(fixtures::sphere_image(25, 8.0), dir + "/ball.mha");
    write_file(dir + "/surface.yaml",
               "input:\n  surface: sphere.vtu\noutput:\n  dir: out-surface\nremesh:\n  "
               "edge_length: 0.005\n");
    write_file(dir + "/image.yaml",
               "input:\n  image: ball.mha\noutput:\n  dir: out-image\nremesh:\n  "
               "edge_length: 0.005\n");
    for (const std::string command :
         {"run surface.yaml", "validate surface.yaml", "run image.yaml"}) {
        INFO(command);
        const auto r = run_frontmesh(command + " --quiet", dir);
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK_THAT(r.err, Catch::StartsWith("frontmesh: error: remesh: expected about") &&
                              Catch::Contains("triangles") && Catch::Contains("h = 0.005 mm") &&
                              Catch::Contains("limits.max_memory_gib = 16 GiB"));
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    }
    // Refused before any stage (a run took 1.7 GB and 300 s and more): nothing written.
    CHECK_FALSE(fs::exists(fs::path(dir) / "out-surface"));
    CHECK_FALSE(fs::exists(fs::path(dir) / "out-image"));
    // Raised far enough, the estimate passes validate.
    const auto raised =
        run_frontmesh("validate surface.yaml --set limits.max_memory_gib=65536 --quiet", dir);
    INFO(raised.err);
    CHECK(raised.exit_code == 0);
    // The tetra estimate on its own, straight into tetra.
    write_file(dir + "/tetra.yaml",
               "input:\n  surface: sphere.vtu\noutput:\n  dir: out-tetra\nlimits:\n  "
               "max_memory_gib: 0.0000001\n");
    for (const std::string command : {"run", "validate"}) {
        const auto tetra = run_frontmesh(command + " tetra.yaml --quiet --from tetra", dir);
        INFO(tetra.err);
        CHECK(tetra.exit_code == 2);
        CHECK_THAT(tetra.err, Catch::Contains("tetra: expected about") && Catch::Contains("tets") &&
                                  Catch::Contains("limits.max_memory_gib = 1e-07 GiB"));
    }
    CHECK_FALSE(fs::exists(fs::path(dir) / "out-tetra"));
}
