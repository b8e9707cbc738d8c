#!/usr/bin/env bash
# Command 1 of the README: install what is missing, build, run the default example.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh -DFRONTMESH_BUILD_TESTS=OFF
# The left hippocampus of the AAL atlas, from image to refined tets in seconds. The
# whole Colin27 brain (examples/colin27-brain.yaml) runs the same way in about a minute.
./build/pipeline/frontmesh run examples/aal-hippocampus.yaml
