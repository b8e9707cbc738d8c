#pragma once
// Quality figures of stage results, for summary.json and the log.

#include <string>

#include "pipeline/core/surface_network.h"

namespace frontmesh::pipeline {

/// Figures of a surface network as a JSON object: counts, per-region closedness,
/// orientation and volume, triangle quality (eta of Eq. 2, minimum angles).
std::string surface_figures_json(const core::SurfaceNetwork& surface);

/// One human line of the same figures, for the log.
std::string surface_figures_line(const core::SurfaceNetwork& surface);

/// JSON string literal of `text` (quoted, escaped).
std::string json_quote(const std::string& text);

/// JSON number (finite; NaN and infinities become null).
std::string json_number(double value);

}  // namespace frontmesh::pipeline
