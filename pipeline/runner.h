#pragma once
// The stage runner: the only place that knows about the recipe, checkpoints, hashes,
// timing and the output folder (STYLE §3).

#include <atomic>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/recipe.h"

namespace frontmesh::pipeline {

struct RunOptions {
    std::string
        from;  ///< first stage to run (its input from the previous checkpoint); empty = auto
    std::string until;   ///< last stage to run; empty = the last available
    bool force = false;  ///< run every stage even when its checkpoint is up to date
    bool quiet = false;  ///< no progress on the terminal
    /// Set by the caller to stop the run between units of work (CancelledError). Null: the
    /// runner's own flag, set by SIGINT and SIGTERM while the run lasts (its handlers are
    /// installed for that time and the previous ones put back after).
    const std::atomic<bool>* cancel = nullptr;
    /// Called with the path of each file the run commits (renames into place, or removes
    /// as the first step of replacing it: a stage's .hash, checkpoints/results.hash), in
    /// commit order. An exception from it ends the run at that point as a kill would: tests
    /// stop a run between two renames with it. Null: nothing is called.
    std::function<void(const std::string& path)> on_commit;
    /// Files (name in output.dir, text) written atomically when the run first writes into
    /// its folder, after every check before any work: `frontmesh mesh`'s recipe.yaml, so
    /// that a run refused by those checks leaves nothing behind.
    std::vector<std::pair<std::string, std::string>> files_on_claim;
};

/// Stage names in pipeline order, of the stages this build can run.
const std::vector<std::string>& stage_names();

/// Runs the recipe. Writes checkpoints/NN-STAGE.vtu (+ .hash, .json, the .hash last),
/// checkpoints/results.hash (what the result files were made from), run-surface.pvd and
/// run-volume.pvd (the surface and the tet checkpoints of this run), summary.json,
/// frontmesh.log, what stages hand to their diagnostics sink (diagnostics/STAGE-NAME.vtu)
/// and the final result into recipe.output.dir, all atomically.
/// Returns the path of the final result. Throws InputError for bad input (exit 2),
/// CancelledError when asked to stop (exit 130; summary.json status "interrupted"), other
/// core::Error for failures (exit 1).
std::string run_recipe(const Recipe& recipe, const RunOptions& options);

}  // namespace frontmesh::pipeline
