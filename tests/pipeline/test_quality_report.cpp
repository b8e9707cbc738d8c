// The quality report: histograms that count every element, well-formed SVG and HTML.

#include <cstdlib>
#include <filesystem>
#include <numeric>
#include <random>
#include <string>

#include <catch2/catch.hpp>

#include "pipeline/core/quality.h"
#include "pipeline/quality_report.h"
#include "tests/fixtures/phantoms.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
namespace fs = std::filesystem;

namespace {
template <class A>
std::size_t sum(const A& a) {
    return std::accumulate(a.begin(), a.end(), std::size_t{0});
}
}  // namespace

TEST_CASE("quality histograms count every element", "[pipeline][report]") {
    core::TetMesh mesh = fixtures::cube_tet_mesh(3, 1.0, true);
    const auto h = pipeline::quality_histograms(mesh);
    CHECK(sum(h.tet_skewness) == mesh.tet_count());
    CHECK(sum(h.surface_skewness) == mesh.face_count());
    CHECK(sum(h.dihedral) == 6 * mesh.tet_count());
    CHECK(sum(h.min_dihedral) == mesh.tet_count());
    // Kuhn tets: skewness 0.5 (bin 10 of 20), dihedral angles 45, 60 and 90 degrees.
    CHECK(h.tet_skewness[9] + h.tet_skewness[10] == mesh.tet_count());
    CHECK(h.min_dihedral_deg == Approx(45.0));
    CHECK(h.max_dihedral_deg == Approx(90.0));
    // 45, 60 and 90 degrees sit on bin edges: either neighbour.
    CHECK(h.dihedral[8] + h.dihedral[9] + h.dihedral[11] + h.dihedral[12] + h.dihedral[17] +
              h.dihedral[18] ==
          6 * mesh.tet_count());
    CHECK(h.regions.size() == 2);
    CHECK(h.regions.at(1).tets + h.regions.at(2).tets == mesh.tet_count());
    CHECK(h.tet_over_08 == 0);
    // Right isosceles surface triangles: eta = 1 - 2/(3 sqrt 3 / 2) = 0.2302 (bin 4).
    CHECK(h.surface_skewness[4] == mesh.face_count());
}

TEST_CASE("quality report files", "[pipeline][report]") {
    core::TetMesh before = fixtures::cube_tet_mesh(4, 1.0, true);
    core::TetMesh after = before;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> d(-0.3, 0.3);
    for (std::size_t v = static_cast<std::size_t>(before.surface_vertices); v < before.node_count();
         ++v)
        for (int k = 0; k < 3; ++k) before.xyz[3 * v + static_cast<std::size_t>(k)] += d(rng);
    const auto hb = pipeline::quality_histograms(before);
    REQUIRE(hb.tet_over_08 > 0);  // a tail to annotate

    const std::string dir = fixtures::temp_dir("quality_report");
    const auto files = pipeline::write_quality_report(dir, after, &before, "jittered <cube>");
    REQUIRE(files.size() == 5);
    for (const auto& f : files) CHECK(fs::file_size(f) > 500);
    const std::string html = frontmesh::testing::slurp(dir + "/report.html");
    CHECK_THAT(html, Catch::Contains("jittered &lt;cube&gt;"));
    CHECK_THAT(html, Catch::Contains("before refine"));
    CHECK(html.find("<svg") != std::string::npos);
    CHECK(html.find("src=") == std::string::npos);  // self-contained
    // Every file parses as XML (the HTML without its doctype).
    for (const char* f :
         {"surface_skewness.svg", "tet_skewness.svg", "dihedral.svg", "min_dihedral.svg"}) {
        INFO(f);
        const std::string cmd =
            "/usr/bin/python3 -c \"import sys, xml.etree.ElementTree as E; "
            "r = E.parse(sys.argv[1]).getroot(); assert r.tag.endswith('svg')\" '" +
            dir + "/" + f + "' > /dev/null 2>&1";
        if (std::system("/usr/bin/python3 -c 'pass' > /dev/null 2>&1") == 0)
            CHECK(std::system(cmd.c_str()) == 0);
    }
    // The count of skewed tets before refinement is written above its bars.
    const std::string tet_svg = frontmesh::testing::slurp(dir + "/tet_skewness.svg");
    CHECK_THAT(tet_svg, Catch::Contains("before refine"));
    std::size_t first = 16;
    while (hb.tet_skewness[first] == 0) ++first;
    CHECK_THAT(tet_svg, Catch::Contains(">" + std::to_string(hb.tet_skewness[first]) + "</text>"));
}
