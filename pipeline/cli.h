#pragma once

namespace frontmesh::pipeline {

/// Runs the frontmesh command line; returns the process exit code
/// (0 success, 2 bad input or recipe, 1 internal failure).
int run_cli(int argc, char** argv);

}  // namespace frontmesh::pipeline
