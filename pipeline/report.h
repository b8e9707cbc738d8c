#pragma once
// Quality figures of stage results, for summary.json and the log.

#include <string>
#include <vector>

#include "pipeline/core/quality.h"
#include "pipeline/core/surface_network.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::pipeline {

/// Figures of a surface network, computed once: `json` is an object with counts,
/// per-region closedness, orientation and volume, and triangle quality (eta of Eq. 2,
/// minimum angles); `line` is one human line of the same figures, for the log.
struct SurfaceReport {
    std::string json;
    std::string line;
};
SurfaceReport surface_report(const core::SurfaceNetwork& surface);

/// Figures of a tetrahedral mesh (volume::check_tet_mesh): `json` holds validity counts,
/// volumes (tets vs enclosed by the boundary), skewness (Eq. 1) and dihedral figures with
/// histograms, overall and per region; `valid` is the verdict; `line` one human line.
/// `figures`, when given, are core::tet_figures of every tet in order (else computed).
struct TetReport {
    std::string json;
    std::string line;
    bool valid = false;
};
TetReport tet_report(const core::TetMesh& mesh,
                     const std::vector<core::TetFigures>* figures = nullptr);

/// JSON string literal of `text` (quoted, escaped).
std::string json_quote(const std::string& text);

/// JSON number (finite; NaN and infinities become null).
std::string json_number(double value);

}  // namespace frontmesh::pipeline
