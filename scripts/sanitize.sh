#!/usr/bin/env bash
# The AddressSanitizer + UndefinedBehaviorSanitizer build of the test suite, with the
# libFuzzer targets, and a bounded fuzz run (issue 21). Needs clang
# (scripts/install-deps.sh). Builds into build-san/.
#   scripts/sanitize.sh [CTEST ARGS]   the whole suite (about an hour on 2 cores), e.g. -R io:
#   scripts/sanitize.sh --ci           what .ci/run runs after scripts/test.sh: the core, io,
#                                      surface and volume tests (the readers, predicates,
#                                      kernels and meshing stages; the two that extract the
#                                      whole AAL atlas beside the fuzz run); all the
#                                      pipeline tests (the command
#                                      line, recipes, output folders, bad input,
#                                      interruptions, end-to-end runs, clients); one torture
#                                      seed per family and the tetra regression surfaces;
#                                      the fuzz run
# Tests labelled "asan-slow" are left out (tests/CMakeLists.txt says which and why); they run
# in the normal build. Pipeline tests tagged [asan-slow] mesh real images or run clients
# (snakemake, ccx, FEniCSx, a CMake build): 3 to 7 times slower under ASan (a capped
# phantom 18 s -> 124 s), the 15 of them 4 min 17 s on two processes; CI runs them.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-san -DCMAKE_BUILD_TYPE=Release -DFRONTMESH_BUILD_TESTS=ON \
  -DFRONTMESH_FUZZ=ON -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++
ci=0
if [[ "${1:-}" == "--ci" ]]; then
  ci=1
  shift
fi
if ((ci)); then
  cmake --build build-san -j"$(nproc)" --target test_core test_io test_surface test_volume \
    test_pipeline frontmesh fuzz_recipe fuzz_image fuzz_surface fuzz_mesh
else
  cmake --build build-san -j"$(nproc)"
fi
export ASAN_OPTIONS=abort_on_error=1
export LSAN_OPTIONS="suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
if ((ci)); then
  (cd build-san && ctest --output-on-failure -j"$(nproc)" -R '^(core|io|surface|volume):' \
    -E '^surface:extract: AAL atlas' -LE asan-slow "$@")
  # Catch2's tag filter (ctest does not see the tags), in two processes: the test names
  # dealt alternately into two lists (-f reads one name per line; a comma is escaped).
  lists=build-san/tests/tmp/asan-lists
  rm -rf "$lists"
  mkdir -p "$lists"
  # (Catch2 exits with the number of names it listed.)
  { build-san/tests/test_pipeline --list-test-names-only || true; } |
    sed 's/^ *//' | grep -v '^$' | sed 's/,/\\,/g' |
    awk -v d="$lists" '{ print > (d "/part" (NR % 2)) }'
  if [[ ! -s $lists/part0 || ! -s $lists/part1 ]]; then
    echo "sanitize.sh: test_pipeline listed no tests" >&2
    exit 1
  fi
  build-san/tests/test_pipeline -f "$lists/part0" > "$lists/log0" 2>&1 &
  first=$!
  build-san/tests/test_pipeline -f "$lists/part1" > "$lists/log1" 2>&1 &
  second=$!
  failed=0
  wait "$first" || failed=1
  wait "$second" || failed=1
  if ((failed)); then
    cat "$lists/log0" "$lists/log1"
    exit 1
  fi
  tail -n 2 "$lists/log0" "$lists/log1"
  # The torture corpus under the sanitizers, in two processes: one seed of each family
  # (65 s) and the two tetra regression surfaces (69 s of CPU). The normal build runs the
  # larger subset and the remesh regression (over 300 s under ASan), the full run all.
  python=/usr/bin/python3
  # (Absolute paths: run.py runs each case in its own folder.)
  "$python" tests/torture/run.py --seeds 0-7 -j 1 --timeout 600 \
    --frontmesh "$PWD/build-san/pipeline/frontmesh" --out "$PWD/build-san/tests/torture" \
    > build-san/tests/torture.log 2>&1 &
  first=$!
  "$python" tests/torture/regressions.py --only 'tetra-*' --timeout 600 \
    --frontmesh "$PWD/build-san/pipeline/frontmesh" --out "$PWD/build-san/tests/regressions" \
    > build-san/tests/regressions.log 2>&1 &
  second=$!
  wait "$first" || failed=1
  wait "$second" || failed=1
  tail -n 1 build-san/tests/torture.log build-san/tests/regressions.log
  if ((failed)); then
    cat build-san/tests/torture.log build-san/tests/regressions.log
    exit 1
  fi
else
  (cd build-san && ctest --output-on-failure -j"$(nproc)" -LE asan-slow "$@")
fi
if ((ci)); then
  # The two tests that extract the whole AAL atlas (about 200 s under ASan) run beside the
  # fuzz run, which takes one core.
  (cd build-san && ctest --output-on-failure -R '^surface:extract: AAL atlas') \
    > build-san/tests/aal-extract.log 2>&1 &
  aal=$!
  # A fixed seed (fuzz.sh: a finding's input is printed into the log, to be replayed).
  fuzz_failed=0
  FRONTMESH_FUZZ_SEED=${FRONTMESH_FUZZ_SEED:-1} bash scripts/fuzz.sh build-san \
    "${FRONTMESH_FUZZ_SECONDS:-25}" || fuzz_failed=1
  aal_failed=0
  wait "$aal" || aal_failed=1
  tail -n 3 build-san/tests/aal-extract.log
  if ((aal_failed)); then
    cat build-san/tests/aal-extract.log
    exit 1
  fi
  ((fuzz_failed == 0)) || exit 1
else
  bash scripts/fuzz.sh build-san "${FRONTMESH_FUZZ_SECONDS:-25}"
fi
