#pragma once
// The stage runner: the only place that knows about the recipe, checkpoints, hashes,
// timing and the output folder (STYLE §3).

#include <string>

#include "pipeline/recipe.h"

namespace frontmesh::pipeline {

struct RunOptions {
    std::string from;   ///< first stage to run (its input from the previous checkpoint); empty = auto
    std::string until;  ///< last stage to run; empty = the last available
    bool force = false; ///< run every stage even when its checkpoint is up to date
    bool quiet = false; ///< no progress on the terminal
};

/// Stage names in pipeline order, of the stages this build can run.
const std::vector<std::string>& stage_names();

/// Runs the recipe. Writes checkpoints/NN-STAGE.vtu (+ .hash), run.pvd, summary.json,
/// frontmesh.log and the final result into recipe.output.dir, all atomically.
/// Returns the path of the final result. Throws InputError for bad input (exit 2),
/// other core::Error for failures (exit 1).
std::string run_recipe(const Recipe& recipe, const RunOptions& options);

}  // namespace frontmesh::pipeline
