#!/usr/bin/env bash
# The bundle's scripts (scripts/bundle.sh, scripts/check-bundle.sh,
# scripts/sysroot.sh, scripts/debian-archive.sh) refuse bad input as every
# lockstep command does: one line on stderr, exit status 2, before anything is
# built, fetched or written. CTest bundle.scripts_refuse_bad_input.
#
#   tests/cli/bundle_scripts_bad_input.sh SOURCE_DIR
set -uo pipefail
source_dir="${1:?usage: bundle_scripts_bad_input.sh SOURCE_DIR}"
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
failures=0
checked=0

# refuses WORD SCRIPT ARGS...: exit 2, one line on stderr naming WORD, nothing
# on stdout, no file left in the scratch directory.
refuses() {
  local word="$1" script="$2"
  shift 2
  local status
  (cd "$scratch" && "$source_dir/scripts/$script" "$@") >"$scratch.out" 2>"$scratch.err"
  status=$?
  checked=$((checked + 1))
  local lines
  lines=$(wc -l <"$scratch.err")
  if [ "$status" != 2 ] || [ "$lines" != 1 ] || [ -s "$scratch.out" ] || ! grep -q -- "$word" "$scratch.err" ||
     [ -n "$(ls -A "$scratch")" ]; then
    echo "FAILED: $script $* -> status $status, $lines lines on stderr (expected 2, one line naming '$word'):" >&2
    cat "$scratch.err" "$scratch.out" >&2
    failures=$((failures + 1))
  fi
  rm -f "$scratch.out" "$scratch.err"
}

refuses "sparc" bundle.sh --arch sparc
refuses "--bogus" bundle.sh --bogus
refuses "not a configured build" bundle.sh --build-dir "$scratch/none"
refuses "give one" bundle.sh --arch x86_64 --build-dir "$scratch"
refuses "usage" check-bundle.sh
refuses "no bundle" check-bundle.sh "$scratch/none.tar.gz"
: >"$scratch.tar.gz"
refuses "buster" check-bundle.sh "$scratch.tar.gz" --glibc buster
refuses "2.28" check-bundle.sh "$scratch.tar.gz" --max-glibc 2.2x
rm -f "$scratch.tar.gz"
refuses "sparc" sysroot.sh --arch sparc
refuses "--arch" sysroot.sh
refuses "download or source" debian-archive.sh fetch --suite bookworm --into "$scratch/x" libc6
refuses "buster" debian-archive.sh download --suite buster --arch amd64 --into "$scratch/x" libc6
refuses "i386" debian-archive.sh download --suite bookworm --arch i386 --into "$scratch/x" libc6
refuses "no package" debian-archive.sh download --suite bookworm --arch amd64 --into "$scratch/x"

echo "$((checked - failures)) passed, $failures failed"
[ "$failures" = 0 ]
