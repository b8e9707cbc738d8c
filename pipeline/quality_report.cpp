#include "pipeline/quality_report.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "io/atomic_file.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"

namespace frontmesh::pipeline {
namespace {

constexpr const char* kColours[] = {"#9aa7b8", "#2f6db5", "#e07b28", "#4b9b4b"};

std::size_t bin_of(double value, double lo, double hi, int bins) {
    const double t = (value - lo) / (hi - lo) * bins;
    if (!(t > 0)) return 0;  // also NaN
    return static_cast<std::size_t>(std::min(t, double(bins - 1)));
}

std::string escaped(const std::string& s) {
    std::string out;
    for (char c : s) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

std::string fixed(double v, int digits) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(digits) << v;
    return s.str();
}

std::string percent(std::size_t part, std::size_t whole) {
    return whole ? fixed(100.0 * double(part) / double(whole), 4) + "%" : "-";
}

/// A "nice" upper bound for a percentage axis: 1, 2 or 5 times a power of ten.
double nice_ceiling(double v) {
    if (v <= 0) return 1.0;
    const double p = std::pow(10.0, std::floor(std::log10(v)));
    for (double m : {1.0, 2.0, 5.0, 10.0})
        if (m * p >= v) return m * p;
    return 10 * p;
}

template <std::size_t N>
std::vector<std::size_t> as_vector(const std::array<std::size_t, N>& a) {
    return std::vector<std::size_t>(a.begin(), a.end());
}

}  // namespace

QualityHistograms quality_histograms(const core::TetMesh& mesh,
                                     const std::vector<core::TetFigures>* figures) {
    FM_CHECK(figures == nullptr || figures->size() == mesh.tet_count());
    QualityHistograms h;
    constexpr int kS = QualityHistograms::kSkewBins, kD = QualityHistograms::kDihedralBins;
    for (const auto& f : mesh.faces) {
        const double eta =
            core::triangle_skewness(mesh.point(f[0]), mesh.point(f[1]), mesh.point(f[2]));  // Eq. 2
        ++h.surface_skewness[bin_of(eta, 0, 1, kS)];
        h.surface_mean += eta;
        if (eta > 0.8) ++h.surface_over_08;
    }
    h.faces = mesh.face_count();
    if (h.faces) h.surface_mean /= double(h.faces);
    for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
        const auto& q = mesh.tets[t];
        const core::TetFigures f = figures != nullptr
                                       ? (*figures)[t]
                                       : core::tet_figures(mesh.point(q[0]), mesh.point(q[1]),
                                                           mesh.point(q[2]), mesh.point(q[3]));
        const double eps = f.skewness;  // Eq. 1
        ++h.tet_skewness[bin_of(eps, 0, 1, kS)];
        h.tet_mean += eps;
        h.tet_max = std::max(h.tet_max, eps);
        if (eps > 0.8) ++h.tet_over_08;
        double tmin = 180.0;
        for (const double angle : f.dihedral_deg) {
            ++h.dihedral[bin_of(angle, 0, 180, kD)];
            tmin = std::min(tmin, angle);
            h.max_dihedral_deg = std::max(h.max_dihedral_deg, angle);
        }
        ++h.min_dihedral[bin_of(tmin, 0, 180, kD)];
        h.min_dihedral_deg = std::min(h.min_dihedral_deg, tmin);
        auto& r = h.regions[mesh.region[t]];
        ++r.tets;
        r.mean += eps;
        if (eps > 0.8) ++r.over_08;
        r.min_dihedral_deg = std::min(r.min_dihedral_deg, tmin);
    }
    h.tets = mesh.tet_count();
    if (h.tets) h.tet_mean /= double(h.tets);
    for (auto& [label, r] : h.regions) r.mean /= double(std::max<std::size_t>(r.tets, 1));
    return h;
}

std::string svg_histogram(const std::string& title, const std::string& x_label, double lo,
                          double hi, const std::vector<HistogramSeries>& series, double mark_from) {
    constexpr double W = 720, H = 340, L = 64, R = 16, T = 40, B = 52;
    const double pw = W - L - R, ph = H - T - B;
    std::size_t bins = 0;
    double top = 0;
    for (const auto& s : series) {
        bins = std::max(bins, s.counts.size());
        std::size_t total = 0;
        for (std::size_t c : s.counts) total += c;
        for (std::size_t c : s.counts)
            if (total) top = std::max(top, 100.0 * double(c) / double(total));
    }
    top = nice_ceiling(top);
    std::ostringstream o;
    o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H
      << "\" viewBox=\"0 0 " << W << ' ' << H
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
    o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    o << "<text x=\"" << W / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">"
      << escaped(title) << "</text>\n";
    // Axes, grid and ticks.
    for (int i = 0; i <= 5; ++i) {
        const double y = T + ph - ph * i / 5.0;
        o << "<line x1=\"" << L << "\" y1=\"" << y << "\" x2=\"" << L + pw << "\" y2=\"" << y
          << "\" stroke=\"#e4e4e4\"/>\n<text x=\"" << L - 6 << "\" y=\"" << y + 4
          << "\" text-anchor=\"end\">" << fixed(top * i / 5.0, top < 5 ? 2 : 1) << "</text>\n";
    }
    for (int i = 0; i <= 10; ++i) {
        const double x = L + pw * i / 10.0;
        o << "<line x1=\"" << x << "\" y1=\"" << T + ph << "\" x2=\"" << x << "\" y2=\""
          << T + ph + 5 << "\" stroke=\"black\"/>\n<text x=\"" << x << "\" y=\"" << T + ph + 18
          << "\" text-anchor=\"middle\">" << fixed(lo + (hi - lo) * i / 10.0, hi - lo > 10 ? 0 : 1)
          << "</text>\n";
    }
    o << "<line x1=\"" << L << "\" y1=\"" << T + ph << "\" x2=\"" << L + pw << "\" y2=\"" << T + ph
      << "\" stroke=\"black\"/>\n<line x1=\"" << L << "\" y1=\"" << T << "\" x2=\"" << L
      << "\" y2=\"" << T + ph << "\" stroke=\"black\"/>\n";
    o << "<text x=\"" << L + pw / 2 << "\" y=\"" << H - 10 << "\" text-anchor=\"middle\">"
      << escaped(x_label) << "</text>\n<text transform=\"translate(16 " << T + ph / 2
      << ") rotate(-90)\" text-anchor=\"middle\">elements (%)</text>\n";
    // Bars: series side by side within each bin.
    const double bw = bins ? pw / double(bins) : pw;
    const double sw = 0.84 * bw / double(std::max<std::size_t>(series.size(), 1));
    for (std::size_t s = 0; s < series.size(); ++s) {
        std::size_t total = 0;
        for (std::size_t c : series[s].counts) total += c;
        const char* colour = kColours[(series.size() == 1 ? 1 : s) % 4];
        for (std::size_t b = 0; b < series[s].counts.size(); ++b) {
            const std::size_t c = series[s].counts[b];
            if (c == 0 || total == 0) continue;
            const double pct = 100.0 * double(c) / double(total);
            const double h = std::max(ph * pct / top, 0.8);  // a tail bin stays visible
            const double x = L + bw * double(b) + 0.08 * bw + sw * double(s);
            o << "<rect x=\"" << fixed(x, 2) << "\" y=\"" << fixed(T + ph - h, 2) << "\" width=\""
              << fixed(sw, 2) << "\" height=\"" << fixed(h, 2) << "\" fill=\"" << colour
              << "\"><title>" << escaped(series[s].name) << ": " << c << " (" << fixed(pct, 4)
              << "%)</title></rect>\n";
            if (lo + (hi - lo) * double(b) / double(bins) >= mark_from - 1e-12)
                o << "<text x=\"" << fixed(x + sw / 2, 2) << "\" y=\"" << fixed(T + ph - h - 3, 2)
                  << "\" text-anchor=\"middle\" font-size=\"9\" fill=\"" << colour << "\">" << c
                  << "</text>\n";
        }
    }
    // Legend.
    for (std::size_t s = 0; s < series.size(); ++s) {
        const double y = T + 6 + 16.0 * double(s);
        o << "<rect x=\"" << L + pw - 190 << "\" y=\"" << y
          << "\" width=\"12\" height=\"12\" fill=\"" << kColours[(series.size() == 1 ? 1 : s) % 4]
          << "\"/>\n<text x=\"" << L + pw - 172 << "\" y=\"" << y + 10 << "\">"
          << escaped(series[s].name) << "</text>\n";
    }
    o << "</svg>\n";
    return o.str();
}

std::vector<std::string> write_quality_report(const std::string& dir, const core::TetMesh& mesh,
                                              const core::TetMesh* before,
                                              const std::string& title) {
    if (!before)
        return write_quality_report(dir, mesh, static_cast<const QualityHistograms*>(nullptr),
                                    title);
    const QualityHistograms prior = quality_histograms(*before);
    return write_quality_report(dir, mesh, &prior, title);
}

std::vector<std::string> write_quality_report(const std::string& dir, const core::TetMesh& mesh,
                                              const QualityHistograms* before_histograms,
                                              const std::string& title,
                                              const std::vector<core::TetFigures>* figures) {
    namespace fs = std::filesystem;
    const QualityHistograms after = quality_histograms(mesh, figures);
    const bool before = before_histograms != nullptr;
    const QualityHistograms prior = before ? *before_histograms : QualityHistograms{};

    const std::string surface_svg = svg_histogram(
        "Surface triangles: skewness (Eq. 2), " + std::to_string(after.faces) + " triangles",
        "skewness eta", 0, 1, {{"surface", as_vector(after.surface_skewness)}}, 0.8);
    std::vector<HistogramSeries> tets;
    if (before)
        tets.push_back(
            {"before refine (" + std::to_string(prior.tets) + ")", as_vector(prior.tet_skewness)});
    tets.push_back(
        {std::string(before ? "after refine" : "tets") + " (" + std::to_string(after.tets) + ")",
         as_vector(after.tet_skewness)});
    const std::string tet_svg =
        svg_histogram("Tetrahedra: skewness (Eq. 1)", "skewness epsilon", 0, 1, tets, 0.8);
    std::vector<HistogramSeries> dihedral;
    if (before) dihedral.push_back({"before refine", as_vector(prior.dihedral)});
    dihedral.push_back(
        {before ? "after refine" : "all dihedral angles", as_vector(after.dihedral)});
    const std::string dihedral_svg =
        svg_histogram("Dihedral angles (all six per tet)", "degrees", 0, 180, dihedral);
    std::vector<HistogramSeries> min_dihedral;
    if (before) min_dihedral.push_back({"before refine", as_vector(prior.min_dihedral)});
    min_dihedral.push_back(
        {before ? "after refine" : "smallest angle per tet", as_vector(after.min_dihedral)});
    const std::string min_dihedral_svg =
        svg_histogram("Smallest dihedral angle per tet", "degrees", 0, 180, min_dihedral);

    const fs::path out(dir);
    std::vector<std::string> written;
    for (const auto& [name, svg] :
         {std::pair<std::string, const std::string*>{"surface_skewness.svg", &surface_svg},
          {"tet_skewness.svg", &tet_svg},
          {"dihedral.svg", &dihedral_svg},
          {"min_dihedral.svg", &min_dihedral_svg}}) {
        io::write_text_atomically((out / name).string(), *svg);
        written.push_back((out / name).string());
    }

    std::ostringstream h;
    h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>frontmesh "
         "quality report: "
      << escaped(title)
      << "</title>\n<style>body{font-family:sans-serif;max-width:760px;margin:2em auto;color:#222}"
      << "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px "
         "8px;text-align:right}"
      << "th{background:#f2f2f2}td:first-child,th:first-child{text-align:left}svg{display:block;"
         "margin:1em 0}"
      << "</style></head><body>\n<h1>Quality report</h1>\n<p>" << escaped(title) << ": "
      << mesh.node_count() << " nodes, " << after.tets << " tetrahedra, " << after.regions.size()
      << " region" << (after.regions.size() == 1 ? "" : "s") << ", " << after.faces
      << " surface triangles (boundary and interfaces).</p>\n";
    auto row = [&](const std::string& what, const std::string& b, const std::string& a) {
        h << "<tr><td>" << what << "</td>" << (before ? "<td>" + b + "</td>" : "") << "<td>" << a
          << "</td></tr>\n";
    };
    h << "<table><tr><th>tetrahedra</th>"
      << (before ? "<th>before refine</th><th>after refine</th>" : "<th>mesh</th>") << "</tr>\n";
    row("tets", std::to_string(prior.tets), std::to_string(after.tets));
    row("mean skewness (Eq. 1)", fixed(prior.tet_mean, 4), fixed(after.tet_mean, 4));
    row("max skewness", fixed(prior.tet_max, 4), fixed(after.tet_max, 4));
    row("skewness &gt; 0.8",
        std::to_string(prior.tet_over_08) + " (" + percent(prior.tet_over_08, prior.tets) + ")",
        std::to_string(after.tet_over_08) + " (" + percent(after.tet_over_08, after.tets) + ")");
    row("min dihedral angle (deg)", fixed(prior.min_dihedral_deg, 2),
        fixed(after.min_dihedral_deg, 2));
    row("max dihedral angle (deg)", fixed(prior.max_dihedral_deg, 2),
        fixed(after.max_dihedral_deg, 2));
    h << "</table>\n<table><tr><th>surface triangles</th><th></th></tr>\n<tr><td>triangles</td><td>"
      << after.faces << "</td></tr>\n<tr><td>mean skewness (Eq. 2)</td><td>"
      << fixed(after.surface_mean, 4) << "</td></tr>\n<tr><td>skewness &gt; 0.8</td><td>"
      << after.surface_over_08 << " (" << percent(after.surface_over_08, after.faces)
      << ")</td></tr>\n</table>\n";
    h << "<h2>Surface mesh</h2>\n"
      << surface_svg << "<h2>Tetrahedra</h2>\n"
      << tet_svg << "<h2>Dihedral angles</h2>\n"
      << dihedral_svg << min_dihedral_svg;
    h << "<h2>Per region</h2>\n<table><tr><th>region</th><th>tets</th><th>mean skewness</th>"
      << (before ? "<th>mean before refine</th>" : "")
      << "<th>skewness &gt; 0.8</th><th>min dihedral (deg)</th></tr>\n";
    for (const auto& [label, r] : after.regions) {
        h << "<tr><td>" << label << "</td><td>" << r.tets << "</td><td>" << fixed(r.mean, 4)
          << "</td>";
        if (before) {
            const auto it = prior.regions.find(label);
            h << "<td>" << (it != prior.regions.end() ? fixed(it->second.mean, 4) : "-") << "</td>";
        }
        h << "<td>" << r.over_08 << " (" << percent(r.over_08, r.tets) << ")</td><td>"
          << fixed(r.min_dihedral_deg, 2) << "</td></tr>\n";
    }
    h << "</table>\n<p>Skewness: 0 for the equilateral element, 1 for a degenerate one (Eq. 1: "
         "volume, Eq. 2: "
         "area, against the equilateral element of the same circumradius). Counts above 0.8 are "
         "written over "
         "their bars.</p>\n</body></html>\n";
    io::write_text_atomically((out / "report.html").string(), h.str());
    written.push_back((out / "report.html").string());
    return written;
}

}  // namespace frontmesh::pipeline
