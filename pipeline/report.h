#pragma once
// Quality figures of stage results, for summary.json and the log.

#include <string>

#include "pipeline/core/surface_network.h"

namespace frontmesh::pipeline {

/// Figures of a surface network, computed once: `json` is an object with counts,
/// per-region closedness, orientation and volume, and triangle quality (eta of Eq. 2,
/// minimum angles); `line` is one human line of the same figures, for the log.
struct SurfaceReport {
    std::string json;
    std::string line;
};
SurfaceReport surface_report(const core::SurfaceNetwork& surface);

/// JSON string literal of `text` (quoted, escaped).
std::string json_quote(const std::string& text);

/// JSON number (finite; NaN and infinities become null).
std::string json_number(double value);

}  // namespace frontmesh::pipeline
