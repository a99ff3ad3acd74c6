#!/usr/bin/env bash
# Installs what lockstep needs from Debian's packages, and only what is missing.
#
#   scripts/setup.sh          what building and running lockstep needs (and the x86-64
#                             bundle: dpkg-dev unpacks Debian's sources, scripts/sysroot.sh)
#   scripts/setup.sh --cross  that, and what the aarch64 build needs: Debian's cross compiler,
#                             and qemu-user-static, which runs its static programs here
#   scripts/setup.sh --emulated  that, and what the emulated machines need
#                             (scripts/emulated-machine.sh): qemu-system-x86 and
#                             qemu-system-arm (QEMU, pure emulation), busybox-static (the
#                             guests' userland and the initramfs' cpio); it adds Debian's
#                             arm64 architecture to apt, from which the arm64 machine's
#                             kernel and busybox are fetched (nothing of it is installed)
#   scripts/setup.sh --test   that, and what the tests need too (rt-tests, chromium,
#                             libbenchmark-tools: Google Benchmark's compare.py,
#                             spin: the Promela models in tests/spin, compiled with gcc;
#                             iproute2: `ip netns`, two hosts for tests/mpi/netns-hosts.sh;
#                             the emulated machines': CTest emulated.two_socket_16 boots one;
#                             universal-ctags: where each function ends, for the CTest test
#                             function_length, scripts/longest-functions.sh;
#                             the tests cross-build aarch64, so --cross's too)
#
# Idempotent: when everything is present it checks and returns in well under a
# second. Runs apt-get as root, or through sudo; says plainly what it installs.
set -euo pipefail

build_packages=(
  g++ cmake ninja-build pkg-config git
  libbenchmark-dev libgtest-dev libgmock-dev
  libhwloc-dev hwloc
  libboost-dev libck-dev libeigen3-dev libcli11-dev nlohmann-json3-dev libfmt-dev
  python3 python3-numpy python3-scipy python3-matplotlib python3-jinja2 python3-jsonschema
  openmpi-bin libopenmpi-dev
  patchelf  # scripts/bundle.sh: the bundled Open MPI libraries find theirs beside them
  dpkg-dev  # scripts/sysroot.sh: dpkg-source unpacks the sources of the static libraries
)
cross_packages=(g++-aarch64-linux-gnu qemu-user-static)
test_packages=(rt-tests chromium libbenchmark-tools spin iproute2 universal-ctags)
emulated_packages=(qemu-system-x86 qemu-system-arm busybox-static)

packages=("${build_packages[@]}")
foreign_architectures=()
case "${1:-}" in
  --test) packages+=("${cross_packages[@]}" "${test_packages[@]}" "${emulated_packages[@]}"); foreign_architectures=(arm64) ;;
  --cross) packages+=("${cross_packages[@]}") ;;
  --emulated) packages+=("${emulated_packages[@]}"); foreign_architectures=(arm64) ;;
  "") ;;
  *) echo "setup.sh: unknown option '$1' (use --test, --cross, --emulated or nothing)" >&2; exit 2 ;;
esac

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$package" 2>/dev/null || true)
  [ "$status" = installed ] || missing+=("$package")
done
missing_architectures=()
for architecture in "${foreign_architectures[@]}"; do
  dpkg --print-foreign-architectures | grep -qx "$architecture" || missing_architectures+=("$architecture")
done

if [ ${#missing[@]} -eq 0 ] && [ ${#missing_architectures[@]} -eq 0 ]; then
  echo "setup: every package lockstep needs is installed" >&2
  exit 0
fi

if [ "$(id -u)" -eq 0 ]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
  as_root=(sudo -n)
else
  [ ${#missing[@]} -eq 0 ] || echo "setup: missing Debian packages: ${missing[*]}" >&2
  [ ${#missing_architectures[@]} -eq 0 ] || echo "setup: apt lacks the architecture(s) ${missing_architectures[*]}" >&2
  echo "setup: that needs root; run: sudo dpkg --add-architecture ARCH; sudo apt-get update;" \
       "sudo apt-get install --no-install-recommends PACKAGES" >&2
  exit 1
fi

export DEBIAN_FRONTEND=noninteractive
for architecture in "${missing_architectures[@]}"; do
  echo "setup: adding the $architecture architecture to apt (the arm64 emulated machine's kernel and busybox come from it)" >&2
  "${as_root[@]}" dpkg --add-architecture "$architecture"
done
if ! "${as_root[@]}" apt-get update -qq; then
  echo "setup: apt-get update failed: is Debian's package registry reachable?" >&2
  exit 1
fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing from Debian's packages: ${missing[*]}" >&2
  if ! "${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null; then
    echo "setup: apt-get install failed for: ${missing[*]}" >&2
    exit 1
  fi
fi
echo "setup: installed ${#missing[@]} package(s), added ${#missing_architectures[@]} architecture(s)" >&2
