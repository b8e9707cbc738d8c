// Refine on a real surface, for measurements (hidden: run explicitly with "[.bench]").
//   REFINE_SURFACE=/path/surface.vtu REFINE_TETGEN=pYq1.3 REFINE_OUT=/tmp/dir test_volume
//   "[refine-bench]"
// Writes input.vtu (tetgen), refined.vtu and surface.vtu in REFINE_OUT, prints the figures and
// the refine wall time; run meshcheck on them for the outside view.

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <iostream>

#include <catch2/catch.hpp>

#include "io/mesh_io.h"
#include "tests/fixtures/phantoms.h"
#include "tests/volume/refine_fixtures.h"
#include "volume/mesh_check.h"
#include "volume/refine.h"

using namespace frontmesh;

TEST_CASE("Refine a tetgen mesh of a given surface", "[.bench][refine-bench]") {
    const char* surface_path = std::getenv("REFINE_SURFACE");
    const char* flags = std::getenv("REFINE_TETGEN");
    const char* out_dir = std::getenv("REFINE_OUT");
    const std::string dir = out_dir ? out_dir : fixtures::temp_dir("refine_bench");
    const core::SurfaceNetwork surface =
        surface_path ? io::read_surface(surface_path)
                     : fixtures::uv_sphere(10.0, std::getenv("REFINE_SPHERE_N")
                                                     ? std::atoi(std::getenv("REFINE_SPHERE_N"))
                                                     : 24);
    const char* input_path =
        std::getenv("REFINE_INPUT");  // a tet mesh (.vtu), e.g. a tetra checkpoint
    const core::TetMesh input =
        input_path ? io::read_tet_mesh(input_path)
                   : refine_fixtures::tetgen_mesh(surface, dir, flags ? flags : "pYq1.3Q", {},
                                                  std::getenv("REFINE_REUSE") != nullptr);
    const auto before = volume::check_tet_mesh(input);
    std::cout << "input:   " << before.summary() << std::endl;
    volume::RefineParams params;
    if (const char* s = std::getenv("REFINE_SLIVER")) params.sliver_pass = std::string(s) != "0";
    if (const char* s = std::getenv("REFINE_DELAUNAY"))
        params.flip_delaunay_test = std::string(s) != "0";
    if (const char* s = std::getenv("REFINE_PASSES")) params.passes = std::atoi(s);
    if (const char* s = std::getenv("REFINE_SMOOTH_SKEW")) params.smoothing_skewness = std::atof(s);
    const auto start = std::chrono::steady_clock::now();
    const std::clock_t cpu_start = std::clock();
    auto elapsed = [start] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    core::StageContext ctx(
        [&](double f, const std::string& what) {
            std::cout << "  [" << elapsed() << " s] " << f << " " << what << std::endl;
        },
        [](core::LogLevel, const std::string& m) { std::cout << m << std::endl; });
    const core::TetMesh out = volume::refine(input, params, ctx);
    const double seconds = elapsed();
    const auto after = volume::check_tet_mesh(out);
    std::cout << "refined: " << after.summary() << "\n";
    for (const auto& [label, q] : after.region_quality)
        std::cout << "region " << label << ": mean skewness "
                  << before.region_quality.at(label).mean_skewness << " -> " << q.mean_skewness
                  << "\n";
    for (const auto& [name, value] : ctx.counters())
        std::cout << "  " << name << " = " << value << "\n";
    std::cout << "refine time " << seconds << " s wall, "
              << static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC << " s cpu\n";
    CHECK(after.valid());
    if (std::getenv("REFINE_WRITE")) {
        io::write_surface_vtu(surface, dir + "/surface.vtu", {});
        io::write_tet_mesh_vtu(input, dir + "/input.vtu", {});
        io::write_tet_mesh_vtu(out, dir + "/refined.vtu", {});
    }
}
