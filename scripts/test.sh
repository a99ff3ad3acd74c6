#!/usr/bin/env bash
# The whole test suite: install what is missing, build, and run every CTest
# suite in the dev preset, then the concurrency suites under ThreadSanitizer
# and under AddressSanitizer + UndefinedBehaviorSanitizer.
#
#   scripts/test.sh           everything
#   scripts/test.sh --fast    the dev preset only
set -euo pipefail
cd "$(dirname "$0")/.."

presets=(dev tsan asan-ubsan)
[ "${1:-}" = --fast ] && presets=(dev)

scripts/setup.sh --test
jobs=$(nproc)
for preset in "${presets[@]}"; do
  echo "== $preset: configure, build, test" >&2
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j "$jobs"
  ctest --preset "$preset" -j "$jobs"
done
