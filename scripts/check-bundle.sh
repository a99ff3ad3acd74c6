#!/usr/bin/env bash
# Runs a bundle (scripts/bundle.sh) in a root filesystem that holds glibc and
# nothing else: the loader and the glibc libraries the binary links, copied
# from this machine, with /proc, /sys and /dev bound in (hwloc, the affinity
# calls and the clocks read them). No shell, no Python, none of lockstep's
# packages: what runs there runs on a machine with nothing installed.
#
#   scripts/check-bundle.sh BUNDLE.tar.gz [--quick]
#
# Runs `lockstep run --quick`, `c2c` and `delay` there, and checks that
# compare says in one line that it needs Python. --quick runs each with its
# smallest settings (the CTest does). Needs root (chroot, a private mount
# namespace); exits 77, skipped, without it.
set -euo pipefail

bundle="${1:?usage: scripts/check-bundle.sh BUNDLE.tar.gz [--quick]}"
quick="${2:-}"
[ -f "$bundle" ] || { echo "check-bundle: no bundle at $bundle" >&2; exit 2; }
if [ "$(id -u)" != 0 ] || ! unshare -m true 2>/dev/null; then
  echo "check-bundle: skipped: needs root and a private mount namespace (chroot)" >&2
  exit 77
fi

root=$(mktemp -d)
trap 'rm -rf "$root"' EXIT
mkdir -p "$root/opt" "$root/tmp" "$root/proc" "$root/sys" "$root/dev"
tar -xzf "$bundle" -C "$root/opt"
name=$(ls "$root/opt")
lockstep="/opt/$name/bin/lockstep"

# glibc: whatever the binary resolves outside the bundle's lib/.
ldd "$root$lockstep" | awk '$2 == "=>" && $3 ~ /^\// { print $3 } $1 ~ /^\/.*ld-linux/ { print $1 }' | while read -r library; do
  case "$library" in "$root"/*) continue ;; esac
  mkdir -p "$root$(dirname "$library")"
  cp -L "$library" "$root$library"
done
extra=$(find "$root" -path "$root/opt" -prune -o -type f -print | sed "s|^$root||" | sort | tr '\n' ' ')
echo "check-bundle: the root holds the bundle and $extra" >&2

if [ "$quick" = --quick ]; then
  run=(run --quick --threads 2 --sync mailbox --layout per_thread --min-time 1ms --out /tmp/run.json)
  c2c=(c2c --samples 50 --rounds 10 --out /tmp/c2c.json)
  delay=(delay --threads 2 --duration 300ms --out /tmp/delay.json)
else
  run=(run --quick --out /tmp/run.json)
  c2c=(c2c --out /tmp/c2c.json)
  delay=(delay --threads 2 --duration 5s --out /tmp/delay.json)
fi

in_root() {
  unshare -m sh -c '
    root="$1"; shift
    mount --rbind /proc "$root/proc" && mount --rbind /sys "$root/sys" && mount --rbind /dev "$root/dev" &&
    exec chroot "$root" "$@"' check-bundle "$root" "$@"
}

for command in run c2c delay; do
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
echo "check-bundle: $bundle runs lockstep run, c2c and delay with glibc alone" >&2
