#include "pipeline/quality_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>

#include "io/atomic_file.h"
#include "io/label_table.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"

namespace frontmesh::pipeline {
namespace {

constexpr double kNever = std::numeric_limits<double>::infinity();  // no bin marked from above
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

// Running sums of edge lengths, for min, max, mean and standard deviation.
struct EdgeSums {
    std::size_t n = 0;
    double sum = 0.0, sum_sq = 0.0, min = std::numeric_limits<double>::infinity(), max = 0.0;
    void add(double length) {
        ++n;
        sum += length;
        sum_sq += length * length;
        min = std::min(min, length);
        max = std::max(max, length);
    }
    void merge(const EdgeSums& o) {
        n += o.n;
        sum += o.sum;
        sum_sq += o.sum_sq;
        min = std::min(min, o.min);
        max = std::max(max, o.max);
    }
    QualityHistograms::Edges figures() const {
        if (n == 0) return {};
        const double mean = sum / double(n);
        return {min, max, mean, std::sqrt(std::max(sum_sq / double(n) - mean * mean, 0.0))};
    }
};

// Colour of `label` as mesh.vtu's `colour` array has it: the label table's (`colours`),
// else io::default_colour. A function of the label alone, so a region keeps its colour
// across runs with other labels and matches the VTU (a colour per position in the run, as
// before, changed when a label was added before it).
std::string region_colour(core::Label label, const std::map<core::Label, io::Rgb>& colours) {
    const auto it = colours.find(label);
    const io::Rgb rgb = it != colours.end() ? it->second : io::default_colour(label);
    char buf[8];
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
    return buf;
}

// A length for the scale bar: "10", "0.5".
std::string json_free_number(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
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
    std::map<core::Label, EdgeSums> edge_sums;
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
        r.max = std::max(r.max, eps);
        if (eps > 0.8) ++r.over_08;
        r.min_dihedral_deg = std::min(r.min_dihedral_deg, tmin);
        const Eigen::Vector3d a = mesh.point(q[0]), b = mesh.point(q[1]), c = mesh.point(q[2]),
                              d = mesh.point(q[3]);
        r.volume_mm3 += std::abs((b - a).dot((c - a).cross(d - a))) / 6.0;
        auto& e = edge_sums[mesh.region[t]];
        for (const auto& [p0, p1] :
             {std::pair{&a, &b}, {&a, &c}, {&a, &d}, {&b, &c}, {&b, &d}, {&c, &d}})
            e.add((*p1 - *p0).norm());
    }
    h.tets = mesh.tet_count();
    if (h.tets) h.tet_mean /= double(h.tets);
    EdgeSums all;
    for (auto& [label, r] : h.regions) {
        r.mean /= double(std::max<std::size_t>(r.tets, 1));
        r.edges = edge_sums[label].figures();
        all.merge(edge_sums[label]);  // in label order: the same sums for any run
    }
    h.edges = all.figures();
    return h;
}

std::string svg_histogram(const std::string& title, const std::string& x_label, double lo,
                          double hi, const std::vector<HistogramSeries>& series, double mark_from,
                          double mark_below) {
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
            // The count stands upright above its bar (rotated text, as wide as its font
            // size, which is at most the bar's width): counts of neighbouring bars never
            // overlap, whatever the number of bins and series.
            const double bin_lo = lo + (hi - lo) * double(b) / double(bins);
            const double bin_hi = lo + (hi - lo) * double(b + 1) / double(bins);
            if (bin_lo >= mark_from - 1e-12 || bin_hi <= mark_below + 1e-12) {
                const double font = std::min(9.0, 0.95 * sw);
                const double cx = x + sw / 2 + font * 0.35, top = T + ph - h - 3;
                o << "<text class=\"count\" x=\"" << fixed(cx, 2) << "\" y=\"" << fixed(top, 2)
                  << "\" transform=\"rotate(-90 " << fixed(cx, 2) << ' ' << fixed(top, 2)
                  << ")\" font-size=\"" << fixed(font, 2) << "\" fill=\"" << colour << "\">" << c
                  << "</text>\n";
            }
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

std::string svg_cross_section(const core::TetMesh& mesh,
                              const std::map<core::Label, std::string>& names,
                              const std::map<core::Label, io::Rgb>& colours) {
    constexpr double W = 720, L = 16, T = 40, legend_row = 18;
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (std::size_t v = 0; v < mesh.node_count(); ++v) {
        lo = lo.cwiseMin(mesh.point(static_cast<std::int32_t>(v)));
        hi = hi.cwiseMax(mesh.point(static_cast<std::int32_t>(v)));
    }
    std::vector<core::Label> labels(mesh.region.begin(), mesh.region.end());
    std::sort(labels.begin(), labels.end());
    labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    if (mesh.tet_count() == 0) hi = lo = Eigen::Vector3d::Zero();
    const double z0 = 0.5 * (lo.z() + hi.z());
    // The cut of each tet: 3 or 4 points (mm), ordered around their centre, per region.
    // 80 bytes per cut tet.
    struct Cut {
        std::vector<double> xy;          // x, y of every point
        std::vector<std::uint8_t> size;  // points per polygon
    };
    std::map<core::Label, Cut> cuts;
    for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
        const auto& q = mesh.tets[t];
        Eigen::Vector3d p[4];
        for (int k = 0; k < 4; ++k) p[k] = mesh.point(q[k]);
        std::array<double, 4> xs{}, ys{}, angle{};
        std::array<std::size_t, 4> order{0, 1, 2, 3};
        std::size_t n = 0;
        // An edge is cut when its ends lie on either side (below / not below): a half-open
        // rule, so that a tet touching the plane at a node or an edge adds nothing twice.
        for (int a = 0; a < 4; ++a)
            for (int b = a + 1; b < 4; ++b)
                if ((p[a].z() < z0) != (p[b].z() < z0) && n < 4) {
                    const double f = (z0 - p[a].z()) / (p[b].z() - p[a].z());
                    xs[n] = p[a].x() + f * (p[b].x() - p[a].x());
                    ys[n] = p[a].y() + f * (p[b].y() - p[a].y());
                    ++n;
                }
        if (n < 3) continue;
        double cx = 0.0, cy = 0.0;
        for (std::size_t k = 0; k < n; ++k) {
            cx += xs[k] / double(n);
            cy += ys[k] / double(n);
        }
        for (std::size_t k = 0; k < n; ++k) angle[k] = std::atan2(ys[k] - cy, xs[k] - cx);
        // Insertion sort of at most four points around their centre.
        for (std::size_t k = 1; k < n; ++k)
            for (std::size_t j = k; j > 0 && angle[order[j]] < angle[order[j - 1]]; --j)
                std::swap(order[j], order[j - 1]);
        Cut& c = cuts[mesh.region[t]];
        for (std::size_t k = 0; k < n; ++k) {
            c.xy.push_back(xs[order[k]]);
            c.xy.push_back(ys[order[k]]);
        }
        c.size.push_back(static_cast<std::uint8_t>(n));
    }

    // The picture frames the cut (the whole mesh when nothing is cut), +y drawn up.
    Eigen::Vector2d low(lo.x(), lo.y()), high(hi.x(), hi.y());
    if (!cuts.empty()) {
        low = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
        high = -low;
        for (const auto& [label, c] : cuts)
            for (std::size_t k = 0; k + 1 < c.xy.size(); k += 2) {
                low = low.cwiseMin(Eigen::Vector2d(c.xy[k], c.xy[k + 1]));
                high = high.cwiseMax(Eigen::Vector2d(c.xy[k], c.xy[k + 1]));
            }
    }
    const double span_x = std::max(high.x() - low.x(), 1e-9);
    const double span_y = std::max(high.y() - low.y(), 1e-9);
    const double scale = std::min((W - 2 * L) / span_x, 520.0 / span_y);  // px per mm
    const double pw = span_x * scale, ph = span_y * scale;
    const double legend_top = T + ph + 44;
    // The legend names the regions the plane cuts (AAL: 71 of 116 at mid-height), then a
    // line for the rest, which the regions table lists.
    std::vector<core::Label> shown;
    for (const core::Label l : labels)
        if (cuts.count(l)) shown.push_back(l);
    const std::size_t not_cut = labels.size() - shown.size();
    const double H =
        legend_top + legend_row * double((shown.size() + 2) / 3 + (not_cut > 0 ? 1 : 0)) + 10;
    auto px = [&](double x) { return L + (x - low.x()) * scale; };
    auto py = [&](double y) { return T + ph - (y - low.y()) * scale; };
    std::map<core::Label, std::string> paths;  // one SVG path per region, a subpath per tet
    std::map<core::Label, std::size_t> cut;
    for (const auto& [label, c] : cuts) {
        std::ostringstream path;
        std::size_t at = 0;
        for (const std::uint8_t n : c.size) {
            for (std::size_t k = 0; k < n; ++k, at += 2)
                path << (k ? 'L' : 'M') << fixed(px(c.xy[at]), 1) << ','
                     << fixed(py(c.xy[at + 1]), 1);
            path << 'Z';
        }
        paths[label] = path.str();
        cut[label] = c.size.size();
    }

    std::ostringstream o;
    o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << fixed(H, 0)
      << "\" viewBox=\"0 0 " << W << ' ' << fixed(H, 0)
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" "
         "fill=\"white\"/>\n<text x=\""
      << W / 2
      << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">Cross-section at z = " << fixed(z0, 2)
      << " mm (view along z, +y up): the tets cut by the plane</text>\n";
    for (std::size_t i = 0; i < labels.size(); ++i) {
        const auto it = paths.find(labels[i]);
        if (it == paths.end()) continue;
        o << "<path class=\"region\" data-label=\"" << labels[i] << "\" fill=\""
          << region_colour(labels[i], colours) << "\" stroke=\"white\" stroke-width=\"0.4\" d=\""
          << it->second << "\"/>\n";
    }
    // A scale bar of a round length near a fifth of the picture's width.
    const double bar_mm = nice_ceiling(span_x / 6.0);
    o << "<line x1=\"" << L << "\" y1=\"" << fixed(T + ph + 18, 1) << "\" x2=\""
      << fixed(L + bar_mm * scale, 1) << "\" y2=\"" << fixed(T + ph + 18, 1)
      << "\" stroke=\"black\" stroke-width=\"2\"/>\n<text x=\"" << fixed(L + bar_mm * scale + 6, 1)
      << "\" y=\"" << fixed(T + ph + 22, 1) << "\">" << json_free_number(bar_mm) << " mm</text>\n";
    o << "<text x=\"" << fixed(L + pw, 1) << "\" y=\"" << fixed(T + ph + 22, 1)
      << "\" text-anchor=\"end\">x " << fixed(low.x(), 1) << " to " << fixed(high.x(), 1)
      << " mm, y " << fixed(low.y(), 1) << " to " << fixed(high.y(), 1) << " mm</text>\n";
    for (std::size_t i = 0; i < shown.size(); ++i) {
        const double x = L + double(i % 3) * 232.0;
        const double y = legend_top + legend_row * double(i / 3);
        const auto name = names.find(shown[i]);
        std::string text = std::to_string(shown[i]);
        if (name != names.end()) text += " " + name->second;
        if (text.size() > 30) text = text.substr(0, 29) + "...";
        o << "<rect x=\"" << x << "\" y=\"" << y - 11 << "\" width=\"12\" height=\"12\" fill=\""
          << region_colour(shown[i], colours) << "\"/><text x=\"" << x + 17 << "\" y=\"" << y
          << "\">" << escaped(text) << " (" << cut[shown[i]] << " cut)</text>\n";
    }
    if (not_cut > 0)
        o << "<text x=\"" << L << "\" y=\""
          << fixed(legend_top + legend_row * double((shown.size() + 2) / 3), 1) << "\">" << not_cut
          << (not_cut == 1 ? " region" : " regions")
          << " not cut by this plane (in the regions table below)</text>\n";
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
    ReportContext context;
    context.title = title;
    return write_quality_report(dir, mesh, before_histograms, context, figures);
}

std::vector<std::string> write_quality_report(const std::string& dir, const core::TetMesh& mesh,
                                              const QualityHistograms* before_histograms,
                                              const ReportContext& context,
                                              const std::vector<core::TetFigures>* figures) {
    namespace fs = std::filesystem;
    const std::string& title = context.title;
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
    const std::string dihedral_svg = svg_histogram("Dihedral angles (all six per tet)", "degrees",
                                                   0, 180, dihedral, 170.0, 10.0);
    std::vector<HistogramSeries> min_dihedral;
    if (before) min_dihedral.push_back({"before refine", as_vector(prior.min_dihedral)});
    min_dihedral.push_back(
        {before ? "after refine" : "smallest angle per tet", as_vector(after.min_dihedral)});
    const std::string min_dihedral_svg = svg_histogram("Smallest dihedral angle per tet", "degrees",
                                                       0, 180, min_dihedral, kNever, 20.0);

    const std::string section_svg =
        svg_cross_section(mesh, context.region_names, context.region_colours);

    const fs::path out(dir);
    std::vector<std::string> written;
    for (const auto& [name, svg] :
         {std::pair<std::string, const std::string*>{"surface_skewness.svg", &surface_svg},
          {"tet_skewness.svg", &tet_svg},
          {"dihedral.svg", &dihedral_svg},
          {"min_dihedral.svg", &min_dihedral_svg},
          {"cross_section.svg", &section_svg}}) {
        io::write_text_atomically((out / name).string(), *svg);
        written.push_back((out / name).string());
    }

    auto region_name = [&](core::Label label) {
        const auto it = context.region_names.find(label);
        return it != context.region_names.end() ? escaped(it->second) : std::string("-");
    };
    std::ostringstream h;
    h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>frontmesh "
         "quality report: "
      << escaped(title)
      << "</title>\n<style>body{font-family:sans-serif;max-width:1300px;margin:2em auto;"
         "color:#222}table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;"
         "padding:3px 8px;text-align:right;vertical-align:top;white-space:nowrap}"
         "th{background:#f2f2f2;white-space:normal}"
         "td:first-child,th:first-child{text-align:left}td.text{text-align:left}"
         "td.params{text-align:left;font-size:85%;color:#444;max-width:560px;white-space:normal}"
         "svg{display:block;margin:1em 0}.charts{display:flex;flex-wrap:wrap;gap:0 16px}"
         ".swatch{display:inline-block;width:10px;height:10px;margin-right:6px}</style></head>"
         "<body>\n<h1>Quality report</h1>\n<p>"
      << escaped(title) << ": " << mesh.node_count() << " nodes, " << after.tets << " tetrahedra, "
      << after.regions.size() << " region" << (after.regions.size() == 1 ? "" : "s") << ", "
      << after.faces << " surface triangles (boundary and interfaces)"
      << (context.frame.empty() ? "" : ", coordinates in mm, frame " + escaped(context.frame))
      << ".</p>\n";

    // The mesh itself first: what it looks like, then its regions.
    h << "<h2>Cross-section</h2>\n" << section_svg;
    h << "<h2>Regions</h2>\n<table><tr><th>label</th><th>name</th><th>tets</th>"
         "<th>volume (mm&sup3;)</th><th>voxel volume (mm&sup3;)</th><th>difference</th>"
         "<th>mean skewness</th>"
      << (before ? "<th>mean before refine</th>" : "")
      << "<th>max skewness</th><th>skewness &gt; 0.8</th><th>min dihedral (deg)</th>"
         "<th>edge mean &plusmn; sd (mm)</th><th>edge min / max (mm)</th></tr>\n";
    for (const auto& [label, r] : after.regions) {
        const auto voxels = context.voxel_volume_mm3.find(label);
        const bool has_voxels = voxels != context.voxel_volume_mm3.end() && voxels->second > 0;
        h << "<tr><td><span class=\"swatch\" style=\"background:"
          << region_colour(label, context.region_colours) << "\"></span>" << label
          << "</td><td class=\"text\">" << region_name(label) << "</td><td>" << r.tets
          << "</td><td>" << fixed(r.volume_mm3, 2) << "</td><td>"
          << (has_voxels ? fixed(voxels->second, 2) : "-") << "</td><td>"
          << (has_voxels ? fixed(100.0 * (r.volume_mm3 - voxels->second) / voxels->second, 2) + "%"
                         : "-")
          << "</td><td>" << fixed(r.mean, 4) << "</td>";
        if (before) {
            const auto it = prior.regions.find(label);
            h << "<td>" << (it != prior.regions.end() ? fixed(it->second.mean, 4) : "-") << "</td>";
        }
        h << "<td>" << fixed(r.max, 4) << "</td><td>" << r.over_08 << " ("
          << percent(r.over_08, r.tets) << ")</td><td>" << fixed(r.min_dihedral_deg, 2)
          << "</td><td>" << fixed(r.edges.mean_mm, 3) << " &plusmn; " << fixed(r.edges.stddev_mm, 3)
          << "</td><td>" << fixed(r.edges.min_mm, 3) << " / " << fixed(r.edges.max_mm, 3)
          << "</td></tr>\n";
    }
    h << "</table>\n<p>Volume: the tets of the region; voxel volume: its voxels in the image "
         "(count &times; voxel volume), so the difference shows what smoothing the staircase "
         "surface gained or lost. Edge lengths over the six edges of every tet.</p>\n";

    auto row = [&](const std::string& what, const std::string& b, const std::string& a) {
        h << "<tr><td>" << what << "</td>" << (before ? "<td>" + b + "</td>" : "") << "<td>" << a
          << "</td></tr>\n";
    };
    h << "<h2>Whole mesh</h2>\n<table><tr><th>tetrahedra</th>"
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
    row("edge length mean &plusmn; sd (mm)",
        fixed(prior.edges.mean_mm, 3) + " &plusmn; " + fixed(prior.edges.stddev_mm, 3),
        fixed(after.edges.mean_mm, 3) + " &plusmn; " + fixed(after.edges.stddev_mm, 3));
    row("edge length min / max (mm)",
        fixed(prior.edges.min_mm, 3) + " / " + fixed(prior.edges.max_mm, 3),
        fixed(after.edges.min_mm, 3) + " / " + fixed(after.edges.max_mm, 3));
    h << "</table>\n<table><tr><th>surface triangles</th><th></th></tr>\n<tr><td>triangles</td><td>"
      << after.faces << "</td></tr>\n<tr><td>mean skewness (Eq. 2)</td><td>"
      << fixed(after.surface_mean, 4) << "</td></tr>\n<tr><td>skewness &gt; 0.8</td><td>"
      << after.surface_over_08 << " (" << percent(after.surface_over_08, after.faces)
      << ")</td></tr>\n</table>\n";

    if (!context.stages.empty()) {
        h << "<h2>Stages</h2>\n<table><tr><th>stage</th><th>status</th><th>wall time (s)</th>"
             "<th>peak memory (MB; the stage's own, else marked: the process's so far)</th>"
             "<th>parameters</th></tr>\n";
        double total = 0.0;
        for (const auto& stage : context.stages) {
            total += stage.wall_s;
            h << "<tr><td>" << escaped(stage.name) << "</td><td class=\"text\">"
              << (stage.reused ? "reused (timing of the run that made it)" : "ran") << "</td><td>"
              << fixed(stage.wall_s, 2) << "</td><td>" << fixed(stage.peak_rss_mb, 0)
              << (stage.peak_is_process ? " (process)" : "") << "</td><td class=\"params\">";
            for (std::size_t k = 0; k < stage.parameters.size(); ++k) {
                const auto& [key, value] = stage.parameters[k];
                h << (k ? ", " : "") << escaped(key.substr(key.find('.') + 1)) << "&nbsp;=&nbsp;"
                  << escaped(value);
            }
            h << "</td></tr>\n";
        }
        h << "<tr><th>total</th><th></th><th>" << fixed(total, 2)
          << "</th><th></th><th></th></tr>\n</table>\n";
    }

    h << "<h2>Tetrahedra</h2>\n"
      << tet_svg << "<h2>Dihedral angles</h2>\n<div class=\"charts\">" << dihedral_svg
      << min_dihedral_svg << "</div>\n<h2>Surface mesh</h2>\n"
      << surface_svg;
    h << "<p>Skewness: 0 for the equilateral element, 1 for a degenerate one (Eq. 1: volume, "
         "Eq. 2: area, against the equilateral element of the same circumradius). Counts are "
         "written over the bars of the tails: skewness above 0.8, dihedral angles below "
         "10&deg; (all) or 20&deg; (smallest per tet) and above 170&deg;.</p>\n</body></html>\n";
    io::write_text_atomically((out / "report.html").string(), h.str());
    written.push_back((out / "report.html").string());
    return written;
}

}  // namespace frontmesh::pipeline
