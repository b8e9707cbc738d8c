#!/usr/bin/env bash
# Runs every libFuzzer target of a -DFRONTMESH_FUZZ=ON build for a bounded time, one after
# the other (issue 21). Usage: scripts/fuzz.sh [BUILD_DIR] [SECONDS_PER_TARGET]
# Defaults: build-san, 25 s. Each target starts from a scratch copy of its seed corpus in
# tests/fuzz/corpus/TARGET (the committed corpus is not modified); a crash, sanitizer
# report, timeout (> 10 s per input), out-of-memory (> 2 GiB) or InternalError stops the
# target, its input is kept as BUILD_DIR/fuzz/crash-* (or timeout-*, oom-*) and the script
# fails. Reproduce with: BUILD_DIR/tests/fuzz/fuzz_TARGET BUILD_DIR/fuzz/crash-...
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-san}
seconds=${2:-25}
out="$build/fuzz"
mkdir -p "$out"
status=0
# Leaks inside ITK/VTK's own error paths are suppressed (tests/fuzz/lsan.supp); ours count.
export LSAN_OPTIONS="suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0"
for target in recipe image surface mesh; do
  work="$out/corpus-$target"
  rm -rf "$work"
  cp -r "tests/fuzz/corpus/$target" "$work"
  echo "fuzz_$target: ${seconds} s"
  # -jobs/-workers stay at 1: one process, and the machine is shared.
  if ! "$build/tests/fuzz/fuzz_$target" -max_total_time="$seconds" -timeout=10 \
      -rss_limit_mb=2048 -artifact_prefix="$out/" -print_final_stats=1 \
      "$work" > "$out/fuzz_$target.log" 2>&1; then
    echo "fuzz_$target FAILED, see $out/fuzz_$target.log:"
    grep -E "ERROR|fuzz:|SUMMARY|Test unit written" "$out/fuzz_$target.log" | head -20
    status=1
  fi
  grep -E "^#[0-9]+.*DONE|stat::number_of_executed_units|stat::peak_rss_mb" \
    "$out/fuzz_$target.log" | sed "s/^/  /"
done
exit $status
