#!/usr/bin/env bash
# The whole test suite: install what is missing, build, and run every CTest
# suite in the dev preset, then the concurrency suites under ThreadSanitizer
# and under AddressSanitizer + UndefinedBehaviorSanitizer; then the bundles:
# the static x86-64 one (its symbol versions, and a run with Debian 11's
# glibc alone) and the aarch64 cross build with warnings as errors (its
# behaviour suites and its bundle under qemu-user).
#
#   scripts/test.sh           everything
#   scripts/test.sh --fast    the dev preset only
set -euo pipefail
cd "$(dirname "$0")/.."

fast=false
[ "${1:-}" = --fast ] && fast=true
presets=(dev tsan asan-ubsan)
$fast && presets=(dev)

scripts/setup.sh --test
jobs=$(nproc)
for preset in "${presets[@]}"; do
  echo "== $preset: configure, build, test" >&2
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j "$jobs"
  ctest --preset "$preset" -j "$jobs"
done
$fast && exit 0

# The static builds link against the root scripts/sysroot.sh makes (once:
# kept in build/ and reused while its versions hold).
arches=(aarch64)
[ "$(uname -m)" = x86_64 ] && arches=(x86_64 aarch64)
for arch in "${arches[@]}"; do
  preset=aarch64
  [ "$arch" = x86_64 ] && preset=bundle-x86_64
  echo "== $preset: the static root, configure, build, test" >&2
  scripts/sysroot.sh --arch "$arch"
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j "$jobs"
  # Under qemu-user every suite runs tens of times slower: CI runs the short
  # list (the stress suites left out); `ctest --preset aarch64` runs them all.
  short=()
  [ "$preset" = aarch64 ] && short=(-LE stress)
  ctest --preset "$preset" -j "$jobs" "${short[@]}"
done
