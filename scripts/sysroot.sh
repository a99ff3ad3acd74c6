#!/usr/bin/env bash
# The root a static build of lockstep links against (LOCKSTEP_STATIC: the
# bundle-x86_64 and aarch64 presets of CMakePresets.json), made from Debian
# 12's packages, in build/sysroot-<arch>:
#
#   static/   hwloc, Google Benchmark and fmt as static libraries, built from
#             Debian 12's source packages at the versions Debian 12 ships
#             (Debian has no libbenchmark.a nor libfmt.a, and its libhwloc.a
#             needs libudev, which has no static library): hwloc without
#             libudev, libxml2 (its own XML reader serves), I/O discovery and
#             plugins, so that it loads nothing at run time;
#   usr/      (aarch64 only) Debian 12's arm64 packages of every other library
#             lockstep builds with, extracted, not installed (libck-dev's
#             arm64 package cannot be installed beside the amd64 one):
#             the sysroot of cmake/toolchain-aarch64-linux-gnu.cmake.
#
# Everything comes from deb.debian.org through scripts/debian-archive.sh (an
# apt configuration of its own); the host's packages stay as they are. Made
# once: a second call with the same versions returns at once.
#
#   scripts/sysroot.sh --arch x86_64|aarch64
set -euo pipefail
cd "$(dirname "$0")/.."

arch=""
while [ $# -gt 0 ]; do
  case "$1" in
    --arch) arch="${2:?--arch needs x86_64 or aarch64}"; shift 2 ;;
    *) echo "sysroot: unknown argument '$1' (--arch x86_64|aarch64)" >&2; exit 2 ;;
  esac
done
case "$arch" in
  x86_64) debian_arch=amd64; triplet=x86_64-linux-gnu; host=$(uname -m) ;;
  aarch64) debian_arch=arm64; triplet=aarch64-linux-gnu; host="" ;;
  *) echo "sysroot: --arch is x86_64 or aarch64, not '$arch'" >&2; exit 2 ;;
esac
if [ "$arch" = x86_64 ] && [ "$host" != x86_64 ]; then
  echo "sysroot: the x86_64 root is built on an x86-64 machine (this one is $host)" >&2
  exit 2
fi
for tool in "$triplet-gcc" "$triplet-g++" cmake ninja make; do
  command -v "$tool" >/dev/null || { echo "sysroot: needs $tool (scripts/setup.sh installs it)" >&2; exit 2; }
done

# Debian 12's versions (apt-cache showsrc on bookworm).
sources=(hwloc=2.9.0-1 benchmark=1.7.1-1 fmtlib=9.1.0+ds1-2)
# aarch64: the arm64 packages of the libraries lockstep finds with
# find_package or pkg-config (CMakeLists.txt), but for the three above.
arm64_packages=(libboost1.74-dev libeigen3-dev libcli11-dev nlohmann-json3-dev libgtest-dev libgmock-dev
                libck-dev libck0)

root="$PWD/build/sysroot-$arch"
static="$root/static"
compiler=$("$triplet-g++" -dumpfullversion)
wanted="arch $arch; compiler $compiler; sources ${sources[*]}"
[ "$arch" = aarch64 ] && wanted="$wanted; packages ${arm64_packages[*]}"
if [ -f "$root/made" ] && [ "$(cat "$root/made")" = "$wanted" ]; then
  echo "sysroot: $root is made ($wanted)" >&2
  exit 0
fi

# A step whose output would only be noise, shown whole (on stderr) when it fails.
log=$(mktemp)
trap 'rm -f "$log"' EXIT
quietly() {
  if ! "$@" >"$log" 2>&1; then
    tail -n 40 "$log" >&2
    echo "sysroot: failed: $*" >&2
    exit 1
  fi
}

rm -rf "$root"
mkdir -p "$root" "$static"
jobs=$(nproc)
cross_cmake=()
configure_host=()
sysroot_flags=""
if [ "$arch" = aarch64 ]; then
  echo "sysroot: extracting Debian 12's arm64 packages: ${arm64_packages[*]}" >&2
  debs="$root/debs"
  scripts/debian-archive.sh download --suite bookworm --arch "$debian_arch" --into "$debs" "${arm64_packages[@]}"
  for deb in "$debs"/*.deb; do
    dpkg-deb -x "$deb" "$root"
  done
  rm -rf "$debs"
  cross_cmake=(-DCMAKE_TOOLCHAIN_FILE="$PWD/cmake/toolchain-aarch64-linux-gnu.cmake")
  configure_host=(--host="$triplet" CC="$triplet-gcc")
  sysroot_flags="--sysroot=$root"
  export LOCKSTEP_SYSROOT="$root"
fi

echo "sysroot: building ${sources[*]} static for $arch from Debian's sources" >&2
source_dir="$PWD/build/debian-sources"
scripts/debian-archive.sh source --suite bookworm --into "$source_dir" "${sources[@]}"
work="$root/work"
mkdir -p "$work/hwloc"

# hwloc: the library and its headers, none of its tools.
(
  cd "$work/hwloc"
  quietly "$source_dir/hwloc-2.9.0/configure" --prefix="$static" "${configure_host[@]}" \
    CFLAGS="-O2 $sysroot_flags" --enable-static --disable-shared --disable-io --disable-libudev \
    --disable-libxml2 --disable-cairo --disable-plugin-dlopen --disable-plugin-ltdl --disable-doxygen \
    --disable-readme
  quietly make -j "$jobs" -C hwloc install
  quietly make -C include install
  quietly make install-hwlocpkgconfigDATA
)

# Google Benchmark and fmt: their CMake builds, libraries and CMake packages.
cmake_static=(-G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$static" -DBUILD_SHARED_LIBS=OFF
              -DCMAKE_POSITION_INDEPENDENT_CODE=ON "${cross_cmake[@]}")
# GIT_VERSION: Debian's rules give the version so (its patch stops the build
# reading git tags).
quietly cmake -S "$source_dir/benchmark-1.7.1" -B "$work/benchmark" "${cmake_static[@]}" -DGIT_VERSION=1.7.1 \
  -DBENCHMARK_ENABLE_TESTING=OFF -DBENCHMARK_ENABLE_GTEST_TESTS=OFF -DBENCHMARK_ENABLE_WERROR=OFF \
  -DBENCHMARK_ENABLE_LTO=OFF -DBENCHMARK_INSTALL_DOCS=OFF -DBENCHMARK_ENABLE_LIBPFM=OFF
quietly cmake --build "$work/benchmark" -j "$jobs"
quietly cmake --install "$work/benchmark"
quietly cmake -S "$source_dir/fmtlib-9.1.0+ds1" -B "$work/fmt" "${cmake_static[@]}" \
  -DFMT_DOC=OFF -DFMT_TEST=OFF -DFMT_INSTALL=ON
quietly cmake --build "$work/fmt" -j "$jobs"
quietly cmake --install "$work/fmt"
rm -rf "$work"

echo "$wanted" >"$root/made"
echo "sysroot: $root is made ($(du -sh "$root" | cut -f1))" >&2
