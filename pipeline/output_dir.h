#pragma once
// The output folder: checked before any work, claimed with a marker file when first used.

#include <string>

#include "pipeline/recipe.h"

namespace frontmesh::pipeline {

/// The file frontmesh writes into every output folder it creates or first uses.
inline constexpr const char* kOutputMarker = ".frontmesh-output";

/// Throws InputError, one line starting with `origin` ("recipe.yaml:7") and naming
/// output.dir, unless recipe.output.dir may receive a run's files: it resolves, each name
/// fits NAME_MAX and the path PATH_MAX, no part of it is a file, it is not on /proc, /sys,
/// /dev or /run, not the filesystem root, a system folder or the home folder itself, not
/// the folder holding (or any folder containing) the input unless
/// output.allow_input_folder, its nearest existing folder is writable, checkpoints and
/// diagnostics in it are folders, and, when it is not empty, it holds kOutputMarker.
/// Reads the filesystem only (stat, access); creates nothing.
void check_output_dir(const Recipe& recipe, const std::string& origin);

/// Removes the temporary files killed runs left (io::remove_stale_temp_files) in `dir`,
/// its checkpoints/ and diagnostics/, only when `dir` carries kOutputMarker: nothing of a
/// folder frontmesh does not own is touched. Returns how many files were removed.
int remove_stale_temp_files(const std::string& dir);

/// Creates `dir` when needed and writes kOutputMarker into it (atomically, with the
/// version) unless it is there already. Call after check_output_dir.
void claim_output_dir(const std::string& dir);

}  // namespace frontmesh::pipeline
