#!/usr/bin/env bash
# Command 2 of the README: install what is missing, build, run the whole test suite.
# Extra arguments go to ctest, e.g. scripts/test.sh -R extract
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/check-format.sh   # every C++ source as .clang-format says (STYLE §5)
bash scripts/build.sh -DFRONTMESH_BUILD_TESTS=ON
cd build
ctest --output-on-failure -j"$(nproc)" "$@"
