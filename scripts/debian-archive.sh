#!/usr/bin/env bash
# Fetches packages from Debian's archive (deb.debian.org) through an apt
# configuration of its own, kept under build/debian-archive/: the machine's
# apt sources, package lists and dpkg database are neither read nor changed,
# and nothing is installed. apt checks every file against the suite's signed
# index (Debian's keyring, /usr/share/keyrings/debian-archive-keyring.gpg).
#
#   scripts/debian-archive.sh download --suite SUITE --arch ARCH --into DIR PACKAGE[=VERSION]...
#       the packages' .deb files for ARCH (amd64, arm64) into DIR
#   scripts/debian-archive.sh source --suite SUITE --into DIR SOURCE=VERSION...
#       the source packages (named as sources: fmtlib, not libfmt-dev) into
#       DIR, each unpacked with its Debian patches applied (dpkg-source -x) in
#       DIR/<source>-<upstream version>
#
# SUITE: bookworm (Debian 12), bullseye (Debian 11), trixie. Buster (glibc
# 2.28) has left deb.debian.org, so it is not offered. A version that the
# suite no longer carries (a point release replaced it) is said in one line,
# exit 1. scripts/sysroot.sh and scripts/check-bundle.sh use it.
set -euo pipefail
cd "$(dirname "$0")/.."

usage="usage: scripts/debian-archive.sh download --suite SUITE --arch ARCH --into DIR PACKAGE...
       scripts/debian-archive.sh source --suite SUITE --into DIR SOURCE=VERSION..."
action="${1:-}"
case "$action" in
  download | source) shift ;;
  *) echo "debian-archive: the first argument is download or source, not '${action}'" >&2; exit 2 ;;
esac
suite=""
arch=""
into=""
while [ $# -gt 0 ]; do
  case "$1" in
    --suite) suite="${2:?--suite needs bookworm, bullseye or trixie}"; shift 2 ;;
    --arch) arch="${2:?--arch needs amd64 or arm64}"; shift 2 ;;
    --into) into="${2:?--into needs a directory}"; shift 2 ;;
    --*) echo "debian-archive: unknown option '$1'" >&2; echo "$usage" >&2; exit 2 ;;
    *) break ;;
  esac
done
case "$suite" in
  bookworm | bullseye | trixie) ;;
  *) echo "debian-archive: --suite is bookworm, bullseye or trixie, not '$suite'" >&2; exit 2 ;;
esac
if [ "$action" = download ]; then
  case "$arch" in
    amd64 | arm64) ;;
    *) echo "debian-archive: --arch is amd64 or arm64, not '$arch'" >&2; exit 2 ;;
  esac
else
  arch=$(dpkg --print-architecture)
fi
[ -n "$into" ] || { echo "debian-archive: --into DIR is needed" >&2; exit 2; }
[ $# -gt 0 ] || { echo "debian-archive: no package named" >&2; exit 2; }
for tool in apt-get dpkg-deb; do
  command -v "$tool" >/dev/null || { echo "debian-archive: needs $tool (a Debian machine)" >&2; exit 2; }
done
if [ "$action" = source ] && ! command -v dpkg-source >/dev/null; then
  echo "debian-archive: needs dpkg-source (scripts/setup.sh installs dpkg-dev)" >&2
  exit 2
fi
keyring=/usr/share/keyrings/debian-archive-keyring.gpg
[ -r "$keyring" ] || { echo "debian-archive: needs Debian's keyring $keyring (debian-archive-keyring)" >&2; exit 2; }

# One apt state a suite and architecture (or a suite's sources): its own
# sources, lists, cache and an empty dpkg status (nothing counts as installed).
if [ "$action" = download ]; then
  state="$PWD/build/debian-archive/$suite-$arch"
  line="deb [arch=$arch signed-by=$keyring] http://deb.debian.org/debian $suite main"
else
  state="$PWD/build/debian-archive/$suite-source"
  line="deb-src [signed-by=$keyring] http://deb.debian.org/debian $suite main"
fi
mkdir -p "$state/lists/partial" "$state/cache/archives/partial" "$state/parts"
: >"$state/status"
echo "$line" >"$state/sources.list"
apt_options=(
  -o "Dir::Etc::SourceList=$state/sources.list" -o "Dir::Etc::SourceParts=$state/parts"
  -o "Dir::Etc::Preferences=/dev/null" -o "Dir::Etc::PreferencesParts=$state/parts"
  -o "Dir::State::Lists=$state/lists" -o "Dir::State::status=$state/status"
  -o "Dir::Cache=$state/cache" -o "APT::Architecture=$arch" -o "APT::Architectures::=$arch"
  -o "APT::Sandbox::User=$(id -un)" -o "Debug::NoLocking=1" -qq)

# The index is read again when it is a day old: a pinned version that a
# point release replaced then fails here, not with a stale list.
if [ -z "$(find "$state/lists" -maxdepth 1 -name '*_InRelease' -mtime -1 2>/dev/null)" ]; then
  if ! apt-get "${apt_options[@]}" update >"$state/update.log" 2>&1; then
    cat "$state/update.log" >&2
    echo "debian-archive: could not read $suite's index from deb.debian.org" >&2
    exit 1
  fi
fi

mkdir -p "$into"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
if [ "$action" = download ]; then
  (cd "$into" && apt-get "${apt_options[@]}" download "$@") >"$log" 2>&1 || {
    cat "$log" >&2
    echo "debian-archive: $suite ($arch) does not give: $*" >&2
    exit 1
  }
else
  (cd "$into" && apt-get "${apt_options[@]}" source --download-only "$@") >"$log" 2>&1 || {
    cat "$log" >&2
    echo "debian-archive: $suite does not give the sources: $*" >&2
    exit 1
  }
  for package in "$@"; do
    name="${package%%=*}"
    version="${package#*=}"
    dsc="${name}_${version#*:}.dsc"
    [ -f "$into/$dsc" ] || { echo "debian-archive: no $dsc in $into (name the source package: fmtlib, not libfmt-dev)" >&2; exit 1; }
    upstream="${version#*:}"
    upstream="${upstream%-*}"
    rm -rf "${into:?}/$name-$upstream"
    # --no-check: apt has already checked the files against the signed index.
    (cd "$into" && dpkg-source --no-check -x "$dsc" "$name-$upstream") >"$log" 2>&1 || {
      cat "$log" >&2
      echo "debian-archive: dpkg-source could not unpack $dsc" >&2
      exit 1
    }
  done
fi
