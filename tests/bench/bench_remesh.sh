#!/usr/bin/env bash
# Benchmark of the remesh stage on the Colin27 brain (issue 3): wall time and peak memory on
# one and on two threads. Not part of the test suite.
#
# Usage: tests/bench/bench_remesh.sh BUILD_DIR [H_MM]
#   BUILD_DIR  a Release build holding pipeline/frontmesh (and tests/test_surface)
#   H_MM       remesh.edge_length, default 1.55 (about 80k triangles on the brain)
#
# With the stage wired into the runner it times
#   frontmesh run examples/colin27-brain.yaml --from remesh --until remesh --threads N
# after one full run up to repair (its checkpoint is the input). Without it, it falls back
# to the [e2e] test case, whose printed "remesh ... s" is the stage alone (the rest of the
# process time is image reading, extraction, repair and the acceptance checks).
set -euo pipefail
build=${1:?usage: bench_remesh.sh BUILD_DIR [H_MM]}
h=${2:-1.55}
src=$(cd "$(dirname "$0")/../.." && pwd)
out=${TMPDIR:-/tmp}/bench-remesh
mkdir -p "$out"
recipe=$src/examples/colin27-brain.yaml
exe=$build/pipeline/frontmesh

if [[ -x $exe ]] && "$exe" run "$recipe" --set output.dir="$out/colin" --set remesh.edge_length="$h" \
      --until remesh >"$out/prepare.log" 2>&1; then
    for threads in 1 2; do
        echo "== frontmesh remesh, $threads thread(s), h = $h mm"
        /usr/bin/time -v "$exe" run "$recipe" --set output.dir="$out/colin" \
            --set remesh.edge_length="$h" --from remesh --until remesh --threads "$threads" \
            >"$out/run-$threads.log" 2>"$out/time-$threads.txt" || { tail "$out/run-$threads.log"; exit 1; }
        grep -E "Elapsed \(wall|Maximum resident" "$out/time-$threads.txt"
        grep -o '"remesh.faces": [0-9.e+]*' "$out/colin/summary.json" || true
    done
else
    echo "runner without a remesh stage: timing the [e2e] test case instead" >&2
    for threads in 1 2; do
        echo "== test_surface Colin27 remesh, TBB threads $threads, h = $h mm"
        FRONTMESH_REMESH_H=$h TBB_NUM_THREADS=$threads /usr/bin/time -v taskset -c 0-$((threads - 1)) \
            "$build/tests/test_surface" "remesh the Colin27 brain at about 80k triangles" \
            >"$out/test-$threads.log" 2>"$out/time-$threads.txt" || true
        grep -E "Colin27|min angle|remesh [0-9]" "$out/test-$threads.log" | head -3
        grep -E "Elapsed \(wall|Maximum resident" "$out/time-$threads.txt"
    done
fi
