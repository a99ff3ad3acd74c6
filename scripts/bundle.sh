#!/usr/bin/env bash
# The bundle: a tarball from which lockstep's measuring commands (run, c2c,
# delay, falseshare, migrate, topology, verify) run on a Linux machine with
# none of lockstep's packages installed. It carries the binary (bin/),
# compare's and report's Python (share/lockstep/reports: they run where
# Python 3 with its packages is, and say what is missing elsewhere) and a
# README.
#
#   scripts/bundle.sh [--arch x86_64|aarch64] [--out FILE]
#       the static bundle (the default: this machine's architecture): makes
#       the static libraries' root (scripts/sysroot.sh), builds the
#       bundle-x86_64 or aarch64 preset, and writes
#       build/lockstep-<revision>-<arch>-linux.tar.gz. Its binary is static:
#       glibc and every library inside, so it needs no glibc on the target
#       and carries no library; the kernel is the floor (the README in the
#       tarball names it, from the binary's ELF note).
#   scripts/bundle.sh --build-dir DIR [--out FILE]
#       bundles a build already made. A static build's bundle is as above;
#       any other build's carries every shared library its binary loads but
#       glibc's (lib/, found through the binary's run path) and runs where
#       glibc is at least this machine's (tests/cli bundles the dev build so).
#   scripts/bundle.sh --suites [--arch aarch64 | --build-dir DIR] [--out FILE]
#       the bundle of a static build with its behaviour suites beside it (the
#       `behaviour` label of tests/CMakeLists.txt: suites/, the fixture they
#       read, and run-behaviour-suites.sh, which runs them anywhere with a
#       POSIX shell): build/lockstep-suites-<revision>-<arch>-linux.tar.gz.
#
# scripts/check-bundle.sh checks a bundle's symbol versions and runs it in a
# root filesystem that holds glibc (this machine's, or an older Debian's) and
# nothing else.
set -euo pipefail
cd "$(dirname "$0")/.."

build=""
out=""
arch=""
suites=false
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) build="${2:?--build-dir needs a directory}"; shift 2 ;;
    --out) out="${2:?--out needs a file}"; shift 2 ;;
    --arch) arch="${2:?--arch needs x86_64 or aarch64}"; shift 2 ;;
    --suites) suites=true; shift ;;
    *) echo "bundle: unknown argument '$1' (--arch x86_64|aarch64, --build-dir DIR, --suites, --out FILE)" >&2; exit 2 ;;
  esac
done
if [ -n "$build" ] && [ -n "$arch" ]; then
  echo "bundle: --arch builds its own preset; --build-dir bundles a build already made: give one" >&2
  exit 2
fi
case "$arch" in
  "" | x86_64 | aarch64) ;;
  *) echo "bundle: --arch is x86_64 or aarch64, not '$arch'" >&2; exit 2 ;;
esac
if [ -n "$build" ] && [ ! -f "$build/CMakeCache.txt" ]; then
  echo "bundle: $build is not a configured build directory" >&2
  exit 2
fi
[ -n "$build" ] || [ -n "$arch" ] || arch=$(uname -m)
if [ -n "$arch" ]; then
  case "$arch" in
    x86_64) preset=bundle-x86_64 ;;
    aarch64) preset=aarch64 ;;
  esac
  if [ "$arch" = x86_64 ] && [ "$(uname -m)" != x86_64 ]; then
    echo "bundle: the x86_64 bundle is built on an x86-64 machine (this one is $(uname -m))" >&2
    exit 2
  fi
  if $suites && [ "$preset" != aarch64 ]; then
    echo "bundle: --suites comes from the aarch64 preset (or --build-dir of a static build with its tests)" >&2
    exit 2
  fi
fi
for tool in readelf objdump; do
  command -v "$tool" >/dev/null || { echo "bundle: needs $tool (binutils)" >&2; exit 2; }
done

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

cache_value() { sed -n "s/^$1:[A-Z]*=//p" "$build/CMakeCache.txt"; }

if [ -n "$arch" ]; then
  if [ "$arch" = "$(uname -m)" ]; then scripts/setup.sh; else scripts/setup.sh --cross; fi
  scripts/sysroot.sh --arch "$arch"
  quietly cmake --preset "$preset"
  build="build/$preset"
  targets=(lockstep)
  $suites && targets+=(lockstep_behaviour_suites)
  cmake --build --preset "$preset" -j "$(nproc)" --target "${targets[@]}"
else
  targets=(lockstep)
  $suites && targets+=(lockstep_behaviour_suites)
  quietly cmake --build "$build" --target "${targets[@]}"
fi
static=$(cache_value LOCKSTEP_STATIC)
case "$static" in ON | TRUE | 1 | YES) static=true ;; *) static=false ;; esac
if $suites && ! $static; then
  echo "bundle: --suites carries a static build's suites (the aarch64 preset); $build is not static" >&2
  exit 2
fi

binary="$build/bench/lockstep"
# The architecture the binary was built for, from its ELF header.
case "$(readelf -h "$binary" | sed -n 's/^ *Machine: *//p')" in
  *X86-64*) binary_arch=x86_64 ;;
  *AArch64*) binary_arch=aarch64 ;;
  *) echo "bundle: $binary is for neither x86-64 nor AArch64" >&2; exit 1 ;;
esac
# The revision the binary names (found when it was built:
# cmake/build_revision.cmake), run under the build's emulator (qemu-user)
# when it was cross-built.
emulator=$(cache_value CMAKE_CROSSCOMPILING_EMULATOR)
if [ "$binary_arch" != "$(uname -m)" ] && [ -z "$emulator" ]; then
  echo "bundle: $binary is for $binary_arch and no emulator runs it here (scripts/setup.sh --cross installs qemu-user-static)" >&2
  exit 2
fi
version=$(${emulator:+"$emulator"} "$binary" --version) || { echo "bundle: $binary --version failed" >&2; exit 1; }
revision=$(sed -n 's/.*, \([^,)]*\))$/\1/p' <<<"$version")
[ -n "$revision" ] || revision=unknown
name="lockstep-$revision-$binary_arch-linux"
if $suites; then name="lockstep-suites-$revision-$binary_arch-linux"; fi
[ -n "$out" ] || out="build/$name.tar.gz"
staging=$(mktemp -d)
trap 'rm -rf "$staging"' EXIT
root="$staging/$name"

quietly cmake --install "$build" --component bundle --prefix "$root"
if $suites; then quietly cmake --install "$build" --component behaviour_suites --prefix "$root"; fi
# Stripped by the target's own binutils (cmake --install --strip would use the
# host's strip, which does not read an AArch64 binary).
strip_tool=$(cache_value CMAKE_STRIP)
for program in "$root"/bin/* "$root"/suites/*; do
  if [ -e "$program" ]; then "${strip_tool:-strip}" "$program"; fi
done

if $static; then
  # A static PIE names no interpreter and needs no library.
  if readelf -l "$root/bin/lockstep" | grep -q 'INTERP' || readelf -d "$root/bin/lockstep" | grep -q '(NEEDED)'; then
    echo "bundle: $build is a static build, but its binary loads libraries: $(readelf -d "$root/bin/lockstep" | grep '(NEEDED)' | tr -s ' ' | cut -d ' ' -f 6- | tr '\n' ' ')" >&2
    exit 1
  fi
  # The oldest kernel glibc starts on, from the binary's ABI note.
  kernel=$(readelf -n "$root/bin/lockstep" | sed -n 's/.*OS: Linux, ABI: \([0-9.]*\).*/\1/p' | head -n 1)
  floor="kernel $kernel or newer"
  carries="The binary is static (glibc $(getconf GNU_LIBC_VERSION | cut -d ' ' -f 2) and every library inside): it needs no glibc and no library on the machine, and the kernel is the floor."
  mpi="lockstep mpi is not in this build (an MPI program needs the cluster's own MPI and launcher): build lockstep on the cluster."
else
  # Open MPI's libraries name their own directory as their run path
  # (DT_RUNPATH), which hides the binary's from their dependencies: beside
  # each other in lib/, theirs becomes $ORIGIN.
  command -v patchelf >/dev/null || { echo "bundle: needs patchelf (scripts/setup.sh installs it)" >&2; exit 2; }
  for library in "$root"/lib/*.so*; do
    [ -e "$library" ] || continue
    if readelf -d "$library" | grep -q '(RUNPATH)\|(RPATH)'; then
      patchelf --set-rpath '$ORIGIN' "$library"
    fi
  done
  # getconf, not `ldd --version | head -n 1`: head leaves before ldd has
  # written its other lines, ldd dies of SIGPIPE and, under pipefail, the
  # script ended there without a word (bundle.runs_with_glibc_alone failed
  # so, in 1.6 s and silent, in two fresh clones' scripts/test.sh; that
  # pipeline failed 269 times in 3000 here).
  glibc=$(getconf GNU_LIBC_VERSION | cut -d ' ' -f 2)
  floor="glibc $glibc or newer"
  carries="It carries the libraries it loads (lib/), glibc's apart."
  mpi="lockstep mpi needs Open MPI's mpirun on the machine (the bundle carries its libraries, not its launcher)."
fi
# The README: its paragraphs folded at 78 columns, the commands as they are.
{
  echo "lockstep $revision, built on $(. /etc/os-release && echo "$PRETTY_NAME"), for $binary_arch."
  echo
  echo "Runs on any $binary_arch Linux with $floor. $carries Nothing to install:" | fold -s -w 78 | sed 's/ *$//'
  cat <<COMMANDS

    tar -xzf $name.tar.gz
    $name/bin/lockstep run          # the matrix; its JSON goes to results/
    $name/bin/lockstep c2c          # core-to-core latency
    $name/bin/lockstep delay        # real-time delay (SCHED_FIFO needs root or CAP_SYS_NICE)
    $name/bin/lockstep --help       # every command

COMMANDS
  echo "Bring the JSON files back and compare them where lockstep's report tools are ($name/bin/lockstep" \
    "compare A.json B.json, or a lockstep checkout): compare and report need Python 3 with numpy, scipy," \
    "matplotlib, jinja2 and jsonschema, and say so in one line where they are missing. $mpi" |
    fold -s -w 78 | sed 's/ *$//'
} >"$root/README"

mkdir -p "$(dirname "$out")"
tar -C "$staging" -czf "$out.partial" "$name"
mv "$out.partial" "$out"
libraries=$(find "$root" -path "$root/lib/*" -name '*.so*' | wc -l)
echo "bundle: $out ($(du -h "$out" | cut -f1) packed, $(du -sh "$root" | cut -f1) unpacked; $($static && echo static || echo "$libraries libraries"))"
if $suites; then
  echo "bundle: with $(ls "$root/suites" | wc -l) behaviour suites: sh $name/run-behaviour-suites.sh runs them"
fi
