#!/usr/bin/env bash
# CI step: C++ sources must match .clang-format (STYLE §5: 4 spaces, 100 columns).
# Checks the files changed since BASE (default: the files of every commit, i.e. all
# tracked sources) with Debian's clang-format; prints each offending file and the first
# lines of its diff, exits 1 if any. `scripts/check-format.sh --fix` rewrites them instead.
#   scripts/check-format.sh [--fix] [BASE]
set -euo pipefail
cd "$(dirname "$0")/.."
fix=0
if [ "${1:-}" = "--fix" ]; then fix=1; shift; fi
base=${1:-}
command -v clang-format > /dev/null || { echo "check-format: clang-format missing (scripts/install-deps.sh installs it)"; exit 2; }
if [ -n "$base" ]; then
  mapfile -t files < <(git diff --name-only --diff-filter=d "$base" -- '*.cpp' '*.h')
else
  mapfile -t files < <(git ls-files '*.cpp' '*.h')
fi
bad=0
for f in "${files[@]}"; do
  if [ "$fix" = 1 ]; then clang-format -i "$f"; continue; fi
  if ! diff -q <(clang-format "$f") "$f" > /dev/null; then
    echo "check-format: $f is not formatted (scripts/check-format.sh --fix):"
    diff <(clang-format "$f") "$f" | head -8 || true
    bad=1
  fi
done
[ "$fix" = 1 ] && echo "check-format: formatted ${#files[@]} files" && exit 0
[ "$bad" = 0 ] && echo "check-format: ${#files[@]} files formatted as .clang-format says"
exit "$bad"
