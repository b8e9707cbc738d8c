#pragma once
// The run's quality report (issue 5, item 7): histograms of the surface triangles' skewness
// (Eq. 2), of the tets' skewness (Eq. 1) before and after refinement, and of the dihedral
// angles, as SVG images and one self-contained report.html (as the paper's Figs. 10, 12, 15).

#include <array>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "io/label_table.h"
#include "pipeline/core/quality.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::pipeline {

/// Histograms of one mesh. Plain doubles: these report, they decide nothing.
struct QualityHistograms {
    static constexpr int kSkewBins = 20;                    ///< over [0, 1], 0.05 wide
    static constexpr int kDihedralBins = 36;                ///< over [0, 180] degrees, 5 wide
    std::array<std::size_t, kSkewBins> surface_skewness{};  ///< mesh.faces, Eq. 2
    std::array<std::size_t, kSkewBins> tet_skewness{};      ///< Eq. 1
    std::array<std::size_t, kDihedralBins> dihedral{};      ///< all six angles of every tet
    std::array<std::size_t, kDihedralBins> min_dihedral{};  ///< smallest angle per tet
    std::size_t faces = 0, tets = 0;
    std::size_t surface_over_08 = 0, tet_over_08 = 0;  ///< skewness > 0.8
    double surface_mean = 0.0, tet_mean = 0.0, tet_max = 0.0;
    double min_dihedral_deg = 180.0, max_dihedral_deg = 0.0;
    /// Edge lengths over the six edges of every tet (an edge counts once per tet it is in).
    struct Edges {
        double min_mm = 0.0, max_mm = 0.0, mean_mm = 0.0, stddev_mm = 0.0;
    };
    Edges edges;
    /// Per region: tets, volume, mean and worst skewness, tets with skewness > 0.8, smallest
    /// dihedral angle, edge lengths.
    struct Region {
        std::size_t tets = 0, over_08 = 0;
        double mean = 0.0, max = 0.0, min_dihedral_deg = 180.0, volume_mm3 = 0.0;
        Edges edges;
    };
    std::map<core::Label, Region> regions;
};

/// What report.html tells beyond the mesh's own figures (issue 22, item 8); every part may
/// be empty.
struct ReportContext {
    std::string title = "frontmesh run";              ///< heads the page (e.g. the recipe)
    std::map<core::Label, std::string> region_names;  ///< from the label table
    /// From the label table (io::LabelTable::colour); a label not here gets
    /// io::default_colour, as in mesh.vtu's `colour` array.
    std::map<core::Label, io::Rgb> region_colours;
    std::map<core::Label, double> voxel_volume_mm3;  ///< per label: its voxels' volume
    std::string frame;                               ///< "lps" or "ras"
    /// One stage of the run: timings and the parameters it ran with.
    struct Stage {
        std::string name;
        bool reused = false;  ///< its checkpoint was reused: timings of the run that made it
        double wall_s = 0.0, peak_rss_mb = 0.0;
        std::vector<std::pair<std::string, std::string>> parameters;  ///< key, value (YAML)
        /// peak_rss_mb is the process's peak so far, not the stage's (no VmHWM reset).
        bool peak_is_process = false;
    };
    std::vector<Stage> stages;
};

/// A picture of the mesh: the tets cut by the plane z = mid-height of the mesh's bounding
/// box, one polygon per tet drawn in its region's colour (`colours`, else io::default_colour:
/// the colours of mesh.vtu; outlined, so elements show), with a legend of region names
/// (`names`, else the labels) and a millimetre scale. Self-contained SVG text, about 100
/// bytes per cut tet. O(tets).
std::string svg_cross_section(const core::TetMesh& mesh,
                              const std::map<core::Label, std::string>& names = {},
                              const std::map<core::Label, io::Rgb>& colours = {});

/// Histograms of `mesh` (deterministic; O(tets + faces)). `figures`, when given, are
/// core::tet_figures of every tet in order (else computed here).
QualityHistograms quality_histograms(const core::TetMesh& mesh,
                                     const std::vector<core::TetFigures>* figures = nullptr);

/// An SVG bar chart of one or more histograms over [lo, hi] (same bin count), bars as a
/// percentage of each series' total, side by side per bin; counts of the bins starting at
/// or above `mark_from` (e.g. skewness 0.8) or ending at or below `mark_below` (e.g. 20
/// degrees) written above their bars, upright text no wider than its bar so that no two
/// counts overlap. Self-contained SVG text.
struct HistogramSeries {
    std::string name;
    std::vector<std::size_t> counts;
};
std::string svg_histogram(const std::string& title, const std::string& x_label, double lo,
                          double hi, const std::vector<HistogramSeries>& series,
                          double mark_from = 2.0, double mark_below = -1.0);

/// Writes surface_skewness.svg, tet_skewness.svg, dihedral.svg and report.html into `dir`
/// (atomically; the folder is created). `before` is the mesh before refinement (the tetra
/// stage's output) or null; `title` heads the page (e.g. the recipe file). Returns the paths
/// written. Throws IoError naming a file that cannot be written.
std::vector<std::string> write_quality_report(const std::string& dir, const core::TetMesh& mesh,
                                              const core::TetMesh* before = nullptr,
                                              const std::string& title = "frontmesh run");

/// The same with the histograms of the mesh before refinement (`before` may be null): the
/// runner keeps them from the tetra stage of the same run instead of reading its checkpoint.
/// `figures` as for quality_histograms.
std::vector<std::string> write_quality_report(
    const std::string& dir, const core::TetMesh& mesh, const QualityHistograms* before,
    const std::string& title, const std::vector<core::TetFigures>* figures = nullptr);

/// The full report: names, per-region volumes against the voxels, element sizes, the
/// stages' timings and parameters, the histograms and a cross-section of the mesh
/// (svg_cross_section, also written as cross_section.svg).
std::vector<std::string> write_quality_report(const std::string& dir, const core::TetMesh& mesh,
                                              const QualityHistograms* before,
                                              const ReportContext& context,
                                              const std::vector<core::TetFigures>* figures);

}  // namespace frontmesh::pipeline
