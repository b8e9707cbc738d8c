#!/usr/bin/env bash
# Runs every libFuzzer target of a -DFRONTMESH_FUZZ=ON build for a bounded time, one after
# the other (issue 21). Usage: scripts/fuzz.sh [BUILD_DIR] [SECONDS_PER_TARGET]
# Defaults: build-san, 25 s. Each target starts from a scratch copy of its seed corpus in
# tests/fuzz/corpus/TARGET (the committed corpus is not modified; its regress-* files are
# inputs that once crashed a reader); a crash, sanitizer report, timeout (> 10 s per
# input), out-of-memory (> 2 GiB) or InternalError stops the target, its input is kept as
# BUILD_DIR/fuzz/crash-* (or timeout-*, oom-*, leak-*) and the script fails.
# Reproduce with: BUILD_DIR/tests/fuzz/fuzz_TARGET BUILD_DIR/fuzz/crash-...
#
# FRONTMESH_FUZZ_SEED=N fixes libFuzzer's random seed (CI uses 1). That does not make two
# machines run the same inputs (the corpus is listed in another order, coverage feedback
# differs, the time cut falls elsewhere): a CI finding is therefore printed into the log as
# base64, to be rebuilt with `base64 -d` and replayed. Unset, each run takes a new seed.
# FRONTMESH_FUZZ_REPLAY="surface mesh" runs those targets on their corpus only (each file
# once, no mutation): a quick check that no regress-* input crashes again.
#
# A single allocation the file asks for beyond what the machine has (a damaged array size
# in a VTK XML file asked for 412 GB) makes malloc return null, as glibc does, instead of
# stopping the run (allocator_may_return_null, -malloc_limit_mb): VTK's readers handle that
# as an error. What is really used still stops it at -rss_limit_mb.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-san}
seconds=${2:-25}
out="$build/fuzz"
mkdir -p "$out"
status=0
# Leaks inside ITK/VTK's own error paths are suppressed (tests/fuzz/lsan.supp); ours count.
export LSAN_OPTIONS="suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0"
asan_base="${ASAN_OPTIONS:+$ASAN_OPTIONS:}allocator_may_return_null=1"
seed_option=()
[[ -n "${FRONTMESH_FUZZ_SEED:-}" ]] && seed_option=(-seed="$FRONTMESH_FUZZ_SEED")
replay=" ${FRONTMESH_FUZZ_REPLAY:-} "
for target in recipe image surface mesh; do
  work="$out/corpus-$target"
  rm -rf "$work"
  cp -r "tests/fuzz/corpus/$target" "$work"
  # The VTK readers' allocation stacks are unwound fully (Debian's VTK has no frame
  # pointers): a leak inside VTK then shows the VTK function that made it, which lsan.supp
  # names. It halves the executions per second, so only these two targets pay for it.
  asan="$asan_base"
  [[ $target == surface || $target == mesh ]] &&
    asan="$asan:fast_unwind_on_malloc=0:malloc_context_size=12"
  if [[ $replay == *" $target "* ]]; then
    echo "fuzz_$target: the corpus only"
    budget=(-runs=0)
  else
    echo "fuzz_$target: ${seconds} s"
    budget=(-max_total_time="$seconds")
  fi
  # -jobs/-workers stay at 1: one process, and the machine is shared.
  if ! ASAN_OPTIONS="$asan" "$build/tests/fuzz/fuzz_$target" "${seed_option[@]}" \
      "${budget[@]}" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1048576 \
      -artifact_prefix="$out/" -print_final_stats=1 "$work" > "$out/fuzz_$target.log" 2>&1; then
    echo "fuzz_$target FAILED, see $out/fuzz_$target.log:"
    grep -E "ERROR|fuzz:|SUMMARY|Test unit written" "$out/fuzz_$target.log" | head -20
    # The finding itself, in the log: a CI machine's build folder is gone after the run, so
    # the input is printed (base64, up to 16 KiB) to be rebuilt with `base64 -d`.
    for artifact in $(sed -n "s/.*Test unit written to \([^ ]*\).*/\1/p" \
        "$out/fuzz_$target.log"); do
      if [[ -f $artifact && $(stat -c %s "$artifact") -le 16384 ]]; then
        echo "  input $artifact, base64:"
        base64 -w 100 "$artifact" | sed "s/^/    /"
      fi
    done
    status=1
  fi
  grep -E "^#[0-9]+.*DONE|stat::number_of_executed_units|stat::peak_rss_mb" \
    "$out/fuzz_$target.log" | sed "s/^/  /"
done
exit $status
