#!/usr/bin/env bash
# Command 1 of the README: install what is missing, build, run the default example.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh -DFRONTMESH_BUILD_TESTS=OFF
./build/pipeline/frontmesh run examples/colin27-brain.yaml
