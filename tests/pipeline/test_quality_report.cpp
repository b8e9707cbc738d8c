// The quality report: histograms that count every element, well-formed SVG and HTML.

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numeric>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include <catch2/catch.hpp>

#include "io/label_table.h"
#include "pipeline/core/quality.h"
#include "pipeline/quality_report.h"
#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/skip.h"
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
    REQUIRE(files.size() == 6);
    for (const auto& f : files) CHECK(fs::file_size(f) > 500);
    const std::string html = frontmesh::testing::slurp(dir + "/report.html");
    CHECK_THAT(html, Catch::Contains("jittered &lt;cube&gt;"));
    CHECK_THAT(html, Catch::Contains("before refine"));
    CHECK(html.find("<svg") != std::string::npos);
    CHECK(html.find("src=") == std::string::npos);  // self-contained
    // Every file parses as XML (the HTML without its doctype).
    for (const char* f : {"surface_skewness.svg", "tet_skewness.svg", "dihedral.svg",
                          "min_dihedral.svg", "cross_section.svg"}) {
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

namespace {

// The counts written over the bars of an SVG histogram: x of each (rotated) text and its
// font size, which is its width on the page.
std::vector<std::pair<double, double>> count_labels(const std::string& svg) {
    std::vector<std::pair<double, double>> labels;
    const std::regex text("<text class=\"count\" x=\"([0-9.]+)\"[^>]* font-size=\"([0-9.]+)\"");
    for (auto it = std::sregex_iterator(svg.begin(), svg.end(), text); it != std::sregex_iterator();
         ++it)
        labels.emplace_back(std::stod((*it)[1].str()), std::stod((*it)[2].str()));
    return labels;
}

// Total area (px^2) of the polygons of the cross-section's paths, and their bounding box.
std::pair<double, double> section_areas(const std::string& svg) {
    double area = 0.0, x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    const std::regex path(" d=\"([^\"]*)\"");
    for (auto it = std::sregex_iterator(svg.begin(), svg.end(), path); it != std::sregex_iterator();
         ++it) {
        std::istringstream d((*it)[1].str());
        std::vector<std::pair<double, double>> polygon;
        char c = 0;
        // One pass per point or closing Z of the path.
        while (d >> c) {
            if (c == 'Z') {
                for (std::size_t k = 0; k < polygon.size(); ++k) {
                    const auto& [ax, ay] = polygon[k];
                    const auto& [bx, by] = polygon[(k + 1) % polygon.size()];
                    area += 0.5 * (ax * by - bx * ay);
                }
                polygon.clear();
                continue;
            }
            double x = 0, y = 0;
            char comma = 0;
            d >> x >> comma >> y;
            polygon.emplace_back(x, y);
            x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
    }
    return {std::abs(area), (x1 - x0) * (y1 - y0)};
}

}  // namespace

TEST_CASE("histogram counts never overlap", "[pipeline][report]") {
    // Two series of 36 bins, every bin marked: the worst case of the dihedral charts.
    std::vector<std::size_t> a(36), b(36);
    for (std::size_t i = 0; i < 36; ++i) a[i] = 1000 + i * 37, b[i] = 99999 - i * 11;
    const std::string svg = pipeline::svg_histogram("t", "deg", 0, 180, {{"a", a}, {"b", b}}, 0.0);
    const auto labels = count_labels(svg);
    REQUIRE(labels.size() == 72);
    for (std::size_t i = 0; i < labels.size(); ++i)
        for (std::size_t j = i + 1; j < labels.size(); ++j) {
            INFO(labels[i].first << " " << labels[j].first);
            CHECK(std::abs(labels[i].first - labels[j].first) >=
                  0.5 * (labels[i].second + labels[j].second) - 1e-9);
        }
}

TEST_CASE("report.html: names, per-region volumes and sizes, stages, a cross-section",
          "[pipeline][report]") {
    // Two regions; the mid-height plane z = 1.5 cuts the middle layer of cells (region 1).
    const core::TetMesh mesh = fixtures::cube_tet_mesh(3, 1.0, true);
    const std::string section = pipeline::svg_cross_section(mesh, {{1, "Left & part"}});
    // The cut tets cover the cube's section: their polygons fill its bounding box.
    const auto [area, box] = section_areas(section);
    CHECK(area == Approx(box).epsilon(1e-3));
    CHECK_THAT(section, Catch::Contains("data-label=\"1\"") && Catch::Contains("Left &amp; part") &&
                            Catch::Contains("z = 1.50 mm"));
    // The legend names the regions cut, and counts the others (AAL: 45 of 116 not cut).
    CHECK_THAT(section, !Catch::Contains("data-label=\"2\"") && !Catch::Contains("(0 cut)") &&
                            Catch::Contains("1 region not cut by this plane"));

    pipeline::ReportContext context;
    context.title = "cube";
    context.region_names = {{1, "Left"}, {2, "Right"}};
    const auto h = pipeline::quality_histograms(mesh);
    context.voxel_volume_mm3 = {{1, h.regions.at(1).volume_mm3 * 1.1}, {2, 0.0}};
    context.stages = {{"tetra", false, 1.5, 100.0, {{"tetra.stretching", "1.15"}}, false},
                      {"refine", true, 2.5, 120.0, {{"refine.passes", "3"}}, true}};
    const std::string dir = fixtures::temp_dir("quality_report_context");
    pipeline::write_quality_report(dir, mesh, nullptr, context, nullptr);
    const std::string html = frontmesh::testing::slurp(dir + "/report.html");
    CHECK_THAT(html, Catch::Contains("<td class=\"text\">Left</td>") &&
                         Catch::Contains("<td class=\"text\">Right</td>") &&
                         Catch::Contains("-9.09%") &&  // 1 / 1.1 - 1
                         Catch::Contains("stretching&nbsp;=&nbsp;1.15") &&
                         Catch::Contains("reused") && Catch::Contains("Cross-section") &&
                         Catch::Contains(">120 (process)<") && Catch::Contains(">100<") &&
                         Catch::Contains("edge mean"));
    // Edge lengths of the unit cube's tets: 1, sqrt 2 and sqrt 3.
    // The smallest-angle chart marks only the small angles (below 20 degrees).
    const std::string min_svg = frontmesh::testing::slurp(dir + "/min_dihedral.svg");
    CHECK(count_labels(min_svg).size() <= 2 * 4);
    CHECK(h.edges.min_mm == Approx(1.0));
    CHECK(h.edges.max_mm == Approx(std::sqrt(3.0)));
    CHECK(h.regions.at(1).volume_mm3 + h.regions.at(2).volume_mm3 == Approx(27.0));
}

TEST_CASE("report.html renders in a real browser", "[pipeline][report]") {
    if (std::system("command -v chromium > /dev/null 2>&1") != 0)
        FM_SKIP("chromium is not installed (scripts/install-deps.sh installs it)");
    const std::string dir = fixtures::temp_dir("quality_report_browser");
    pipeline::ReportContext context;
    context.region_names = {{1, "Lower"}, {2, "Upper"}};
    pipeline::write_quality_report(dir, fixtures::cube_tet_mesh(3, 1.0, true), nullptr, context,
                                   nullptr);
    const std::string png = dir + "/report.png";
    const std::string cmd = "bash '" + std::string(FRONTMESH_SOURCE_DIR) +
                            "/scripts/report-screenshot.sh' '" + dir + "/report.html' '" + png +
                            "' 1200x1600 > /dev/null 2>&1";
    REQUIRE(std::system(cmd.c_str()) == 0);
    // A PNG of the page: its signature, and more than a blank page's few bytes.
    const std::string bytes = frontmesh::testing::slurp(png);
    CHECK(bytes.compare(1, 3, "PNG") == 0);
    CHECK(bytes.size() > 20000);
}

namespace {

/// The fill of the legend swatch of `label` in a cross-section SVG ("" when there is none).
std::string legend_colour(const std::string& svg, int label) {
    std::smatch m;
    const std::regex swatch("fill=\"([^\"]*)\"/><text x=\"[^\"]*\" y=\"[^\"]*\">" +
                            std::to_string(label) + "[ (]");
    return std::regex_search(svg, m, swatch) ? m[1].str() : std::string();
}

std::string hex(const io::Rgb& c) {
    char buffer[8];
    std::snprintf(buffer, sizeof buffer, "#%02x%02x%02x", c[0], c[1], c[2]);
    return buffer;
}

}  // namespace

TEST_CASE("report colours are mesh.vtu's label colours, the same in every run",
          "[pipeline][report]") {
    // Regions 1 and 2, both cut by the mid-height plane (x below and above 1.5); then region 1
    // relabelled 9, so that label 2 comes first in the run.
    core::TetMesh mesh = fixtures::cube_tet_mesh(3, 1.0, true);
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
        double x = 0;
        for (const std::int32_t v : mesh.tets[t]) x += mesh.point(v).x() / 4;
        mesh.region[t] = x < 1.5 ? 1 : 2;
    }
    core::TetMesh other = mesh;
    for (core::Label& r : other.region)
        if (r == 1) r = 9;
    const std::string a = pipeline::svg_cross_section(mesh);
    const std::string b = pipeline::svg_cross_section(other);
    CHECK(legend_colour(a, 2) == hex(io::default_colour(2)));
    CHECK(legend_colour(b, 2) == hex(io::default_colour(2)));
    CHECK(legend_colour(a, 1) == hex(io::default_colour(1)));
    CHECK(legend_colour(b, 9) == hex(io::default_colour(9)));
    // The cut polygons of region 1 in its colour.
    CHECK_THAT(a, Catch::Contains("data-label=\"1\" fill=\"" + hex(io::default_colour(1)) + "\""));

    // A label table's colour wins, in the picture and in the region table's swatch.
    io::LabelTable table;
    table.set(2, "Right");
    table.set_colour(2, {10, 20, 30});
    pipeline::ReportContext context;
    context.region_names = table.names();
    context.region_colours = {{2, table.colour(2)}};
    const std::string dir = fixtures::temp_dir("quality_report_colours");
    pipeline::write_quality_report(dir, mesh, nullptr, context, nullptr);
    const std::string html = frontmesh::testing::slurp(dir + "/report.html");
    CHECK_THAT(html,
               Catch::Contains("background:#0a141e\"></span>2<") &&
                   Catch::Contains("background:" + hex(io::default_colour(1)) + "\"></span>1<"));
    CHECK(legend_colour(frontmesh::testing::slurp(dir + "/cross_section.svg"), 2) == "#0a141e");
}
