# Cross-builds lockstep for aarch64 (arm64) Linux on an x86-64 Debian machine,
# with Debian's cross compiler (g++-aarch64-linux-gnu: GCC 12 and its arm64
# glibc 2.36, libstdc++ and libgomp) and a sysroot of Debian 12's arm64
# library packages that scripts/sysroot.sh makes (build/sysroot-aarch64:
# the .debs extracted, so that nothing on the host is installed or replaced;
# hwloc, Google Benchmark and fmt built static from Debian's sources under
# its static/). The aarch64 preset of CMakePresets.json uses it; the build is
# static (LOCKSTEP_STATIC), so its programs run on any arm64 Linux and under
# qemu-user, which the tests use when it is installed (qemu-user-static).
#
#   cmake --preset aarch64          after scripts/sysroot.sh --arch aarch64
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

# The sysroot: build/sysroot-aarch64 beside this file's repository unless
# LOCKSTEP_SYSROOT names another (the environment carries it into CMake's
# try_compile projects, which read this file again).
if(DEFINED ENV{LOCKSTEP_SYSROOT})
  set(lockstep_sysroot "$ENV{LOCKSTEP_SYSROOT}")
else()
  get_filename_component(lockstep_sysroot "${CMAKE_CURRENT_LIST_DIR}/../build/sysroot-aarch64" ABSOLUTE)
endif()
if(NOT EXISTS "${lockstep_sysroot}/usr/include")
  message(FATAL_ERROR "no aarch64 sysroot at ${lockstep_sysroot}: run scripts/sysroot.sh --arch aarch64")
endif()
# The compiler's own glibc, libstdc++ and libgomp (Debian's *-arm64-cross
# packages, under /usr/aarch64-linux-gnu) are found relative to the compiler,
# whatever the sysroot; the sysroot replaces only /usr/include and /usr/lib,
# so no x86-64 header of the host is ever read.
set(CMAKE_SYSROOT "${lockstep_sysroot}")

# Headers, libraries and CMake packages from the sysroot only; programs
# (pkg-config, python3, spin) from the host.
set(CMAKE_FIND_ROOT_PATH "${lockstep_sysroot}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# pkg-config reads the sysroot's .pc files (ck's) and the static hwloc's,
# never the host's.
set(ENV{PKG_CONFIG_DIR} "")
set(ENV{PKG_CONFIG_LIBDIR}
    "${lockstep_sysroot}/static/lib/pkgconfig:${lockstep_sysroot}/usr/lib/aarch64-linux-gnu/pkgconfig:${lockstep_sysroot}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_SYSROOT_DIR} "")
set(ENV{LOCKSTEP_SYSROOT} "${lockstep_sysroot}")

# Tests (gtest_discover_tests, ctest) and scripts/bundle.sh run the static
# arm64 programs under qemu-user on the host (cached, so that the scripts
# read it from CMakeCache.txt).
find_program(LOCKSTEP_QEMU_AARCH64 NAMES qemu-aarch64-static qemu-aarch64)
if(LOCKSTEP_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${LOCKSTEP_QEMU_AARCH64}" CACHE FILEPATH
      "Runs the build's static arm64 programs on this machine (qemu-user)")
endif()
