#!/usr/bin/env bash
# Configures and builds frontmesh (Release) into build/ with all cores; extra arguments go
# to CMake's configure step, e.g. scripts/build.sh -DFRONTMESH_BUILD_TESTS=OFF
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build build -j"$(nproc)"
