#!/usr/bin/env bash
# Checks a bundle (scripts/bundle.sh) as a machine with nothing installed
# would meet it:
#
#  1. symbol versions: `objdump -T` of its binary and of every library it
#     carries; the newest GLIBC_ version each needs is printed, and one above
#     --max-glibc fails the check (a static binary needs none);
#  2. runs it in a root filesystem that holds glibc and nothing else: the
#     loader and the glibc libraries the binary links, copied from this
#     machine (the default), or, with --glibc SUITE, the whole libc6 package
#     of an older Debian (bullseye: glibc 2.31, the oldest Debian's archive
#     gives) for the bundle's architecture; /proc, /sys and /dev are bound in
#     (hwloc, the affinity calls and the clocks read them). No shell, no
#     Python, none of lockstep's packages. An aarch64 bundle runs there under
#     qemu-user (qemu-aarch64-static, itself static, copied into the root).
#
#   scripts/check-bundle.sh BUNDLE.tar.gz [--quick] [--glibc host|bullseye|bookworm] [--max-glibc 2.28]
#   scripts/check-bundle.sh BUNDLE.tar.gz --symbols-only [--max-glibc 2.28]
#
# Runs `lockstep run --quick`, `topology`, `c2c` and `delay` there, and checks
# that compare says in one line that it needs Python. --quick runs each with
# its smallest settings (the CTests do). The runs need root (chroot, a private
# mount namespace); without it the check exits 77, skipped, after the symbol
# versions.
set -euo pipefail
scripts=$(cd "$(dirname "$0")" && pwd)

usage="usage: scripts/check-bundle.sh BUNDLE.tar.gz [--quick] [--glibc host|bullseye|bookworm] [--max-glibc VERSION] [--symbols-only]"
bundle="${1:-}"
[ -n "$bundle" ] && [ "${bundle#--}" = "$bundle" ] || { echo "$usage" >&2; exit 2; }
shift
quick=false
glibc=host
max_glibc=""
symbols_only=false
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=true; shift ;;
    --glibc) glibc="${2:?--glibc needs host, bullseye or bookworm}"; shift 2 ;;
    --max-glibc) max_glibc="${2:?--max-glibc needs a version such as 2.28}"; shift 2 ;;
    --symbols-only) symbols_only=true; shift ;;
    *) echo "check-bundle: unknown argument '$1'" >&2; echo "$usage" >&2; exit 2 ;;
  esac
done
[ -f "$bundle" ] || { echo "check-bundle: no bundle at $bundle" >&2; exit 2; }
case "$glibc" in
  host | bullseye | bookworm) ;;
  *) echo "check-bundle: --glibc is host, bullseye or bookworm, not '$glibc'" >&2; exit 2 ;;
esac
if [ -n "$max_glibc" ] && ! [[ "$max_glibc" =~ ^[0-9]+\.[0-9]+$ ]]; then
  echo "check-bundle: --max-glibc takes a version such as 2.28, not '$max_glibc'" >&2
  exit 2
fi
command -v objdump >/dev/null || { echo "check-bundle: needs objdump (binutils)" >&2; exit 2; }

root=$(mktemp -d)
trap 'rm -rf "$root"' EXIT
mkdir -p "$root/opt" "$root/tmp" "$root/proc" "$root/sys" "$root/dev"
tar -xzf "$bundle" -C "$root/opt"
name=$(ls "$root/opt")
lockstep="/opt/$name/bin/lockstep"

# 1. The newest GLIBC_ symbol version the binary and each carried library
# needs (objdump reads any architecture's ELF).
newest_glibc() {
  objdump -T "$1" 2>/dev/null | grep -o 'GLIBC_[0-9][0-9.]*' | sort -u -V | tail -n 1 || true
}
too_new=false
for object in "$root$lockstep" $(find "$root/opt/$name" -path '*/lib/*' -name '*.so*' -type f | sort); do
  label="${object#"$root/opt/"}"
  version_words=$(newest_glibc "$object")
  if ! readelf -d "$object" 2>/dev/null | grep -q '(NEEDED)' && ! readelf -l "$object" 2>/dev/null | grep -q INTERP &&
     [ "$object" = "$root$lockstep" ]; then
    echo "check-bundle: $label: static, needs no glibc (objdump -T: ${version_words:-no GLIBC_ version})" >&2
    continue
  fi
  version=$(newest_glibc "$object")
  echo "check-bundle: $label: newest ${version:-GLIBC_ version: none}" >&2
  if [ -n "$max_glibc" ] && [ -n "$version" ] &&
     [ "$(printf '%s\n%s\n' "${version#GLIBC_}" "$max_glibc" | sort -V | tail -n 1)" != "$max_glibc" ]; then
    objdump -T "$object" | grep "$version" | head -n 5 >&2
    too_new=true
  fi
done
if $too_new; then
  echo "check-bundle: $bundle needs a glibc newer than $max_glibc" >&2
  exit 1
fi
$symbols_only && exit 0

if [ "$(id -u)" != 0 ] || ! unshare -m true 2>/dev/null; then
  echo "check-bundle: skipped: needs root and a private mount namespace (chroot)" >&2
  exit 77
fi

# The bundle's architecture, from its binary's ELF header; a foreign one runs
# under qemu-user.
case "$(readelf -h "$root$lockstep" | sed -n 's/^ *Machine: *//p')" in
  *X86-64*) bundle_arch=x86_64; debian_arch=amd64 ;;
  *AArch64*) bundle_arch=aarch64; debian_arch=arm64 ;;
  *) echo "check-bundle: the bundle's binary is for neither x86-64 nor AArch64" >&2; exit 1 ;;
esac
emulator=()
if [ "$bundle_arch" != "$(uname -m)" ]; then
  qemu=$(command -v "qemu-$bundle_arch-static" || true)
  [ -n "$qemu" ] || { echo "check-bundle: a $bundle_arch bundle runs here under qemu-$bundle_arch-static (scripts/setup.sh --cross installs it)" >&2; exit 2; }
  cp "$qemu" "$root/qemu-$bundle_arch-static"
  emulator=("/qemu-$bundle_arch-static")
fi

# 2. glibc: this machine's (whatever the binary resolves outside the bundle's
# lib/), or an older Debian's libc6 whole.
if [ "$glibc" = host ]; then
  if [ ${#emulator[@]} -gt 0 ]; then
    echo "check-bundle: a $bundle_arch bundle gets no glibc from this machine: give --glibc bullseye" >&2
    exit 2
  fi
  ldd "$root$lockstep" 2>/dev/null | awk '$2 == "=>" && $3 ~ /^\// { print $3 } $1 ~ /^\/.*ld-linux/ { print $1 }' |
    while read -r library; do
      case "$library" in "$root"/*) continue ;; esac
      mkdir -p "$root$(dirname "$library")"
      cp -L "$library" "$root$library"
    done
  glibc_words="this machine's glibc $(getconf GNU_LIBC_VERSION | cut -d ' ' -f 2)"
else
  "$scripts/debian-archive.sh" download --suite "$glibc" --arch "$debian_arch" --into "$root/debs" libc6
  deb=$(ls "$root"/debs/libc6_*.deb)
  dpkg-deb -x "$deb" "$root"
  rm -rf "$root/debs"
  glibc_words="$glibc's libc6 $(basename "$deb" .deb | cut -d _ -f 2) ($debian_arch)"
fi
extra=$(find "$root" \( -path "$root/opt" -o -path "$root/proc" -o -path "$root/sys" -o -path "$root/dev" \) -prune -o -type f -print |
  sed "s|^$root||" | sort | awk '{ n++ } NR <= 6 { shown = shown " " $0 } END { printf "%s%s", shown, (n > 6 ? " ... (" n " files)" : "") }')
echo "check-bundle: the root holds the bundle,$extra" >&2

if $quick; then
  run=(run --quick --threads 2 --sync mailbox --layout per_thread --min-time 1ms --out /tmp/run.json)
  c2c=(c2c --samples 50 --rounds 10 --out /tmp/c2c.json)
  delay=(delay --threads 2 --duration 300ms --out /tmp/delay.json)
else
  run=(run --quick --out /tmp/run.json)
  c2c=(c2c --out /tmp/c2c.json)
  delay=(delay --threads 2 --duration 5s --out /tmp/delay.json)
fi
topology=(topology --out /tmp/topology.json)

in_root() {
  unshare -m sh -c '
    root="$1"; shift
    mount --rbind /proc "$root/proc" && mount --rbind /sys "$root/sys" && mount --rbind /dev "$root/dev" &&
    exec chroot "$root" "$@"' check-bundle "$root" "${emulator[@]}" "$@"
}

for command in run topology c2c delay; do
  declare -n arguments="$command"
  echo "check-bundle: lockstep ${arguments[*]}" >&2
  in_root "$lockstep" "${arguments[@]}" >"$root/tmp/$command.out" 2>&1 || {
    status=$?
    tail -n 20 "$root/tmp/$command.out" >&2
    echo "check-bundle: lockstep $command ended with status $status in the bare root" >&2
    exit 1
  }
  tail -n 3 "$root/tmp/$command.out" >&2
  [ -s "$root/tmp/$command.json" ] || { echo "check-bundle: lockstep $command wrote no result file" >&2; exit 1; }
done

set +e
in_root "$lockstep" compare /tmp/run.json /tmp/run.json >"$root/tmp/compare.out" 2>&1
status=$?
set -e
if [ "$status" != 2 ] || [ "$(wc -l <"$root/tmp/compare.out")" != 1 ]; then
  cat "$root/tmp/compare.out" >&2
  echo "check-bundle: compare without Python ended with status $status, not one line and 2" >&2
  exit 1
fi
cat "$root/tmp/compare.out" >&2
echo "check-bundle: $bundle runs lockstep run, topology, c2c and delay with $glibc_words alone" >&2
