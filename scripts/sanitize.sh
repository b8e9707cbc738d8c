#!/usr/bin/env bash
# The AddressSanitizer + UndefinedBehaviorSanitizer build of the whole test suite, with the
# libFuzzer targets, and a bounded fuzz run (issue 21); part of .ci/run after
# scripts/test.sh. Needs clang (scripts/install-deps.sh). Builds into build-san/.
# Extra arguments go to ctest, e.g. scripts/sanitize.sh -R io:
# Tests labelled "asan-slow" are left out here (tests/CMakeLists.txt says which and why);
# they run in the normal build.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-san -DCMAKE_BUILD_TYPE=Release -DFRONTMESH_BUILD_TESTS=ON \
  -DFRONTMESH_FUZZ=ON -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++
cmake --build build-san -j"$(nproc)"
export ASAN_OPTIONS=abort_on_error=1
export LSAN_OPTIONS="suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
(cd build-san && ctest --output-on-failure -j"$(nproc)" -LE asan-slow "$@")
bash scripts/fuzz.sh build-san "${FRONTMESH_FUZZ_SECONDS:-25}"
