#!/usr/bin/env bash
# Command 1 of the README: install what is missing, build, run the default example.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh -DFRONTMESH_BUILD_TESTS=OFF
# The left hippocampus of the AAL atlas, from image to refined tets in seconds. The
# Colin27 brain (examples/colin27-brain.yaml) runs the same way but, until the remesh
# stage lands, tetra meshes its 300,000 marching-cubes triangles as they are: slow.
./build/pipeline/frontmesh run examples/aal-hippocampus.yaml
