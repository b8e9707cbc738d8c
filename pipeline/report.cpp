#include "pipeline/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "pipeline/core/quality.h"
#include "volume/mesh_check.h"

namespace frontmesh::pipeline {
namespace {

struct SurfaceFigures {
    std::size_t vertices = 0, faces = 0, regions = 0, closed = 0, oriented = 0;
    double eta_mean = 0, eta_max = 0, min_angle_min = 180, below20 = 0, below30 = 0;
    std::vector<core::RegionBoundaryCheck> checks;
};

SurfaceFigures figures(const core::SurfaceNetwork& s) {
    SurfaceFigures f;
    f.vertices = s.vertex_count();
    f.faces = s.face_count();
    for (const auto& t : s.faces) {
        const auto a = s.point(t[0]), b = s.point(t[1]), c = s.point(t[2]);
        const double eta = core::triangle_skewness(a, b, c);
        const double angle = core::triangle_min_angle_deg(a, b, c);
        f.eta_mean += eta;
        f.eta_max = std::max(f.eta_max, eta);
        f.min_angle_min = std::min(f.min_angle_min, angle);
        f.below20 += angle < 20.0;
        f.below30 += angle < 30.0;
    }
    if (f.faces) {
        f.eta_mean /= double(f.faces);
        f.below20 /= double(f.faces);
        f.below30 /= double(f.faces);
    }
    f.checks = core::check_region_boundaries(s);
    f.regions = f.checks.size();
    for (const auto& c : f.checks) {
        f.closed += c.is_closed();
        f.oriented += c.is_oriented();
    }
    return f;
}

}  // namespace

std::string json_quote(const std::string& text) {
    std::string out = "\"";
    for (unsigned char c : text) {
        switch (c) {
            case '"':
                out += "\\\"";
                break;
            case '\\':
                out += "\\\\";
                break;
            case '\n':
                out += "\\n";
                break;
            case '\t':
                out += "\\t";
                break;
            case '\r':
                out += "\\r";
                break;
            default:
                if (c < 0x20) {
                    char buf[8];
                    std::snprintf(buf, sizeof buf, "\\u%04x", c);
                    out += buf;
                } else {
                    out += static_cast<char>(c);
                }
        }
    }
    return out + "\"";
}

std::string json_number(double value) {
    if (!std::isfinite(value)) return "null";
    std::ostringstream s;
    s.precision(10);
    s << value;
    return s.str();
}

SurfaceReport surface_report(const core::SurfaceNetwork& surface) {
    const SurfaceFigures f = figures(surface);
    std::ostringstream s;
    s << "{\"vertices\": " << f.vertices << ", \"faces\": " << f.faces
      << ", \"regions\": " << f.regions << ", \"regions_closed\": " << f.closed
      << ", \"regions_oriented\": " << f.oriented << ", \"eta_mean\": " << json_number(f.eta_mean)
      << ", \"eta_max\": " << json_number(f.eta_max)
      << ", \"min_angle_deg\": " << json_number(f.min_angle_min)
      << ", \"fraction_min_angle_below_20\": " << json_number(f.below20)
      << ", \"fraction_min_angle_below_30\": " << json_number(f.below30)
      << ", \"region_boundaries\": [";
    for (std::size_t i = 0; i < f.checks.size(); ++i) {
        const auto& c = f.checks[i];
        s << (i ? ", " : "") << "{\"region\": " << c.region << ", \"faces\": " << c.faces
          << ", \"volume_mm3\": " << json_number(c.volume) << ", \"open_edges\": " << c.open_edges
          << ", \"misoriented_edges\": " << c.misoriented_edges
          << ", \"nonmanifold_edges\": " << c.nonmanifold_edges << "}";
    }
    s << "]}";
    char buf[320];
    std::snprintf(
        buf, sizeof buf,
        "%zu vertices, %zu faces, %zu regions (%zu closed, %zu oriented), eta mean %.3f max %.3f, "
        "min angle %.1f deg",
        f.vertices, f.faces, f.regions, f.closed, f.oriented, f.eta_mean, f.eta_max,
        f.min_angle_min);
    return {s.str(), buf};
}

namespace {

template <std::size_t N>
std::string json_counts(const std::array<std::size_t, N>& counts) {
    std::string s = "[";
    for (std::size_t i = 0; i < N; ++i) s += (i ? ", " : "") + std::to_string(counts[i]);
    return s + "]";
}

std::string quality_json(const volume::TetQuality& q) {
    std::ostringstream s;
    s << "{\"tets\": " << q.tets << ", \"skewness_mean\": " << json_number(q.mean_skewness)
      << ", \"skewness_max\": " << json_number(q.max_skewness)
      << ", \"skewness_over_0.8\": " << q.skewness_over_08 << ", \"fraction_skewness_over_0.8\": "
      << json_number(q.tets ? double(q.skewness_over_08) / double(q.tets) : 0.0)
      << ", \"min_dihedral_deg\": " << json_number(q.min_dihedral_deg)
      << ", \"max_dihedral_deg\": " << json_number(q.max_dihedral_deg)
      << ", \"skewness_histogram_0.1\": " << json_counts(q.skewness_histogram)
      << ", \"min_dihedral_histogram_10deg\": " << json_counts(q.dihedral_histogram) << "}";
    return s.str();
}

// The log line of a tet mesh: counts, verdict, volume error and quality. Defect counts
// appear only when some are not zero (a valid mesh's line lists no zeros).
std::string tet_line(const volume::TetMeshCheck& c, std::size_t closed, std::size_t regions) {
    std::ostringstream s;
    s << c.nodes << " nodes, " << c.tets << " tets, " << regions << " region"
      << (regions == 1 ? "" : "s");
    if (closed != regions) s << " (" << closed << " closed)";
    if (c.valid()) {
        s << ", valid";
    } else {
        s << ", INVALID (";
        bool first = true;
        for (const auto& [what, n] :
             {std::pair<const char*, std::size_t>{"inverted", c.inverted_tets},
              {"non-conforming", c.nonconforming_faces},
              {"open", c.open_faces},
              {"missing", c.missing_faces},
              {"wrong side", c.wrong_side_faces},
              {"inner on surface", c.inner_faces_on_surface}})
            if (n) {
                s << (first ? "" : ", ") << what << ' ' << n;
                first = false;
            }
        s << ')';
    }
    const double rel =
        c.enclosed_volume != 0.0 ? (c.volume - c.enclosed_volume) / c.enclosed_volume : 0.0;
    char buf[240];
    std::snprintf(buf, sizeof buf,
                  ", volume %.6g mm^3 (relative error %.2g), skewness mean %.4f max %.4f", c.volume,
                  rel, c.quality.mean_skewness, c.quality.max_skewness);
    s << buf;
    if (c.quality.skewness_over_08) {
        std::snprintf(buf, sizeof buf, ", %zu over 0.8 (%.4f%%)", c.quality.skewness_over_08,
                      c.tets ? 100.0 * double(c.quality.skewness_over_08) / double(c.tets) : 0.0);
        s << buf;
    }
    std::snprintf(buf, sizeof buf, ", min dihedral %.2f deg", c.quality.min_dihedral_deg);
    return s.str() + buf;
}

// The boundary and interface triangles of `mesh` as a surface network, for the
// per-region closedness checks. All nodes are copied: a mesh read from a file need not
// number its surface nodes first.
core::SurfaceNetwork boundary_network(const core::TetMesh& mesh) {
    core::SurfaceNetwork s;
    s.xyz = mesh.xyz;
    s.faces = mesh.faces;
    s.region_in = mesh.region_in;
    s.region_out = mesh.region_out;
    return s;
}

}  // namespace

TetReport tet_report(const core::TetMesh& mesh, const std::vector<core::TetFigures>* figures) {
    const volume::TetMeshCheck c = volume::check_tet_mesh(mesh, figures);
    // Closed and oriented boundaries per region, as for a surface (issue 22: a tetrahedral
    // result had no regions_closed, so the cohort summary's column stayed empty).
    std::size_t closed = 0, oriented = 0;
    const auto checks = core::check_region_boundaries(boundary_network(mesh));
    for (const auto& b : checks) {
        closed += b.is_closed();
        oriented += b.is_oriented();
    }
    std::ostringstream s;
    s << "{\"nodes\": " << c.nodes << ", \"tets\": " << c.tets
      << ", \"boundary_faces\": " << mesh.face_count() << ", \"regions_closed\": " << closed
      << ", \"regions_oriented\": " << oriented << ", \"valid\": " << (c.valid() ? "true" : "false")
      << ", \"inverted_tets\": " << c.inverted_tets
      << ", \"nonconforming_faces\": " << c.nonconforming_faces
      << ", \"open_faces\": " << c.open_faces << ", \"missing_faces\": " << c.missing_faces
      << ", \"wrong_side_faces\": " << c.wrong_side_faces
      << ", \"unused_nodes\": " << c.unused_nodes << ", \"volume_mm3\": " << json_number(c.volume)
      << ", \"enclosed_volume_mm3\": " << json_number(c.enclosed_volume)
      << ", \"quality\": " << quality_json(c.quality) << ", \"regions\": [";
    bool first = true;
    for (const auto& [label, q] : c.region_quality) {
        const auto enclosed = c.region_enclosed_volume.find(label);
        s << (first ? "" : ", ") << "{\"region\": " << label
          << ", \"volume_mm3\": " << json_number(c.region_volume.at(label))
          << ", \"enclosed_volume_mm3\": "
          << json_number(enclosed != c.region_enclosed_volume.end() ? enclosed->second : 0.0)
          << ", \"quality\": " << quality_json(q) << "}";
        first = false;
    }
    s << "]}";
    return {s.str(), tet_line(c, closed, c.region_quality.size()), c.valid()};
}

}  // namespace frontmesh::pipeline
