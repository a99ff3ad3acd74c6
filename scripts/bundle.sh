#!/usr/bin/env bash
# The bundle: a tarball from which lockstep's measuring commands (run, c2c,
# delay, falseshare, migrate, topology, verify) run on an x86-64 Linux whose
# glibc is at least as new as this machine's, with none of lockstep's packages
# installed. It carries the binary (bin/), every shared library the binary
# loads but glibc's (lib/, found through the binary's run path), compare's and
# report's Python (share/lockstep/reports: they run where Python 3 with its
# packages is, and say what is missing elsewhere) and a README.
#
#   scripts/bundle.sh                  build the release preset, write
#                                      build/lockstep-<revision>-x86_64-linux.tar.gz
#   scripts/bundle.sh --build-dir DIR [--out FILE]
#                                      bundle a build already made (tests/cli
#                                      bundles the dev build this way)
#
# scripts/check-bundle.sh runs a bundle in a root filesystem that holds glibc
# and nothing else.
set -euo pipefail
cd "$(dirname "$0")/.."

build=""
out=""
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) build="${2:?--build-dir needs a directory}"; shift 2 ;;
    --out) out="${2:?--out needs a file}"; shift 2 ;;
    *) echo "bundle: unknown argument '$1' (--build-dir DIR, --out FILE)" >&2; exit 2 ;;
  esac
done
if [ -n "$build" ] && [ ! -f "$build/CMakeCache.txt" ]; then
  echo "bundle: $build is not a configured build directory" >&2
  exit 2
fi

# A step whose output would only be noise, shown whole (on stderr) when it
# fails: ninja prints a failing command's errors on its standard output.
quietly() {
  local log
  log=$(mktemp)
  if ! "$@" >"$log" 2>&1; then
    echo "bundle: failed: $*" >&2
    cat "$log" >&2
    rm -f "$log"
    exit 1
  fi
  rm -f "$log"
}

if [ -z "$build" ]; then
  scripts/setup.sh
  cmake --preset release >/dev/null
  cmake --build --preset release -j "$(nproc)" --target lockstep
  build=build/release
else
  quietly cmake --build "$build" --target lockstep
fi
command -v patchelf >/dev/null || { echo "bundle: needs patchelf (scripts/setup.sh installs it)" >&2; exit 2; }

# The revision the binary names (found when it was built: cmake/build_revision.cmake).
version=$("$build/bench/lockstep" --version) || { echo "bundle: $build/bench/lockstep --version failed" >&2; exit 1; }
revision=$(sed -n 's/.*, \([^,)]*\))$/\1/p' <<<"$version")
[ -n "$revision" ] || revision=unknown
name="lockstep-$revision-$(uname -m)-linux"
[ -n "$out" ] || out="build/$name.tar.gz"
staging=$(mktemp -d)
trap 'rm -rf "$staging"' EXIT
root="$staging/$name"

quietly cmake --install "$build" --component bundle --prefix "$root" --strip
# Open MPI's libraries name their own directory as their run path
# (DT_RUNPATH), which hides the binary's from their dependencies: beside each
# other in lib/, theirs becomes $ORIGIN.
for library in "$root"/lib/*.so*; do
  if readelf -d "$library" | grep -q '(RUNPATH)\|(RPATH)'; then
    patchelf --set-rpath '$ORIGIN' "$library"
  fi
done

# getconf, not `ldd --version | head -n 1`: head leaves before ldd has
# written its other lines, ldd dies of SIGPIPE and, under pipefail, the script
# ended there without a word (bundle.runs_with_glibc_alone failed so, in
# 1.6 s and silent, in two fresh clones' scripts/test.sh; that pipeline failed
# 269 times in 3000 here).
glibc=$(getconf GNU_LIBC_VERSION | cut -d ' ' -f 2)
cat >"$root/README" <<README
lockstep $revision, built on $(. /etc/os-release && echo "$PRETTY_NAME") (glibc $glibc), $(uname -m).

Runs on any $(uname -m) Linux with glibc $glibc or newer; nothing else to install:

    tar -xzf $name.tar.gz
    $name/bin/lockstep run          # the matrix; its JSON goes to results/
    $name/bin/lockstep c2c          # core-to-core latency
    $name/bin/lockstep delay        # real-time delay (SCHED_FIFO needs root or CAP_SYS_NICE)
    $name/bin/lockstep --help       # every command

Bring the JSON files back and compare them where lockstep's report tools are
($name/bin/lockstep compare A.json B.json, or a lockstep checkout): compare
and report need Python 3 with numpy, scipy, matplotlib, jinja2 and jsonschema,
and say so in one line where they are missing. lockstep mpi needs Open MPI's
mpirun on the machine (the bundle carries its libraries, not its launcher).
README

mkdir -p "$(dirname "$out")"
tar -C "$staging" -czf "$out.partial" "$name"
mv "$out.partial" "$out"
echo "bundle: $out ($(du -h "$out" | cut -f1) packed, $(du -sh "$root" | cut -f1) unpacked; $(ls "$root/lib" | wc -l) libraries)"
