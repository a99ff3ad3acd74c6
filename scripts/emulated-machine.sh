#!/usr/bin/env bash
# Emulated machines: lockstep on many cores, sockets, NUMA nodes and SMT
# siblings, on a machine that has none of them. Boots one of the topologies
# below in QEMU (pure emulation, TCG) from Debian's packages (a kernel and
# busybox-static, fetched into a cache; qemu from scripts/setup.sh --emulated),
# runs lockstep commands inside from a bundle (scripts/bundle.sh), and brings
# back each command's stdout, stderr and exit status, the files it wrote, and
# the guest kernel's own view of its topology.
#
#   scripts/emulated-machine.sh TOPOLOGY [options] [-- 'COMMAND' ...]
#   scripts/emulated-machine.sh --list
#
#   TOPOLOGY            a name from the table below (--list prints it)
#   -- 'COMMAND' ...    shell command lines run in the guest, in order, with
#                       `lockstep` on the PATH, in the directory brought back
#                       as DIR/results: -- 'lockstep topology --out topology.json'
#   --commands FILE     the command lines from a file, one a line (# comments);
#                       default, without either: lockstep topology --out topology.json
#   --bundle FILE       the lockstep bundle to run (scripts/bundle.sh's tar.gz, of the
#                       topology's architecture, glibc-dynamic or static); default
#                       for x86_64: scripts/bundle.sh builds the release preset's
#   --out DIR           where the files come back (must not exist, or be empty);
#                       default build/emulated/TOPOLOGY-<UTC timestamp>
#   --timeout DURATION  the bound on the whole machine, boot to power-off (90s, 10m,
#                       1h; default: the topology's)
#   --cache DIR         where the kernels and busybox are kept (default
#                       $LOCKSTEP_EMULATED_CACHE, else build/emulated-cache)
#
# DIR holds console.log (the guest's console), machine.txt (the topology, the
# qemu command, the bundle and what was carried with it), guest-kernel/
# (topology.txt: the sysfs files of every CPU's topology and caches and every
# NUMA node's CPUs, one "path<TAB>content" line a file; cpuinfo, dmesg, uname,
# cmdline), commands/<n>.command, .stdout, .stderr, .status (the exit status,
# or why there is none), .seconds, and results/ (what the commands wrote).
#
# Exit status: 0 the machine ran every command and each exited 0; 1 it ran
# them and some did not exit 0 (each named on stderr); 2 bad input, or
# something missing (qemu, a kernel, busybox, the bundle), said in one line
# before anything boots, with nothing created; 3 the machine did not finish
# within the timeout, or its files did not come back whole (DIR then holds
# console.log alone).
#
# No timing means anything inside: each vCPU is a host thread of the
# emulator, and 16 or 64 of them share this machine's CPUs. What the machines
# prove is behaviour: topology, placement, pinning, exit status, files.
set -euo pipefail
cd "$(dirname "$0")/.."

# The topologies. cpus: QEMU's -smp (its topology as the guest is told it);
# nodes: the CPUs of each NUMA node, '/' between nodes ('-': one node); memory:
# the whole machine's, split evenly over its nodes; timeout: the default bound.
topologies='
name           arch     cpus                                   nodes          memory timeout shape
two-socket-16  x86_64   16,sockets=2,cores=4,threads=2         0-7/8-15       4G     10m     two packages x 4 cores x 2 threads, a NUMA node each (Intel)
ccd-16         x86_64   16,sockets=1,dies=2,cores=4,threads=2  -              2G     10m     one package of two dies x 4 cores x 2 threads, an L3 per die, one NUMA node (the AMD CCD shape)
two-socket-64  x86_64   64,sockets=2,cores=16,threads=2        0-31/32-63     4G     40m     two packages x 16 cores x 2 threads, a NUMA node each (Intel)
arm64-8        aarch64  8,sockets=2,clusters=2,cores=2         0-3/4-7        2G     10m     Neoverse-N1: two sockets x 2 clusters x 2 cores, a NUMA node a socket, no SMT
'

fail() { echo "emulated-machine: $*" >&2; exit 2; }
usage="usage: scripts/emulated-machine.sh TOPOLOGY [--bundle FILE] [--out DIR] [--timeout DURATION] [--commands FILE] [--cache DIR] [-- 'COMMAND' ...]"

topology_row() { awk -v name="$1" 'NF && $1 == name' <<<"$topologies"; }
topology_names() { awk 'NF && $1 != "name" { printf "%s%s", sep, $1; sep = ", " }' <<<"$topologies"; }

# A duration with a unit (90s, 10m, 1h) in seconds; empty if it is not one.
seconds_of() {
  case "$1" in
    *[!0-9smh]* | "" | [smh]*) return 0 ;;
    *s) echo "${1%s}" ;;
    *m) echo $((${1%m} * 60)) ;;
    *h) echo $((${1%h} * 3600)) ;;
  esac
}

# ---- the command line
[ $# -gt 0 ] || fail "$usage"
case "$1" in
  --list) sed '/^$/d' <<<"$topologies"; exit 0 ;;
  -h | --help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
  -*) fail "the topology comes first (one of: $(topology_names)); $usage" ;;
esac
topology="$1"; shift
row=$(topology_row "$topology")
[ -n "$row" ] || fail "no topology '$topology' (one of: $(topology_names))"
read -r _ arch smp nodes memory default_timeout shape <<<"$row"

bundle="" out="" timeout="" commands_file="" cache="${LOCKSTEP_EMULATED_CACHE:-build/emulated-cache}"
commands=()
value() { [ -n "${2:-}" ] || fail "$1 needs a value; $usage"; }
while [ $# -gt 0 ]; do
  case "$1" in
    --bundle) value "$@"; bundle="$2"; shift 2 ;;
    --out) value "$@"; out="$2"; shift 2 ;;
    --timeout) value "$@"; timeout="$2"; shift 2 ;;
    --commands) value "$@"; commands_file="$2"; shift 2 ;;
    --cache) value "$@"; cache="$2"; shift 2 ;;
    --) shift; commands=("$@"); break ;;
    *) fail "unknown argument '$1'; $usage" ;;
  esac
done
timeout_s=$(seconds_of "${timeout:-$default_timeout}")
[ -n "$timeout_s" ] && [ "$timeout_s" -ge 30 ] ||
  fail "--timeout '${timeout}' is not a duration of 30s or more (90s, 10m, 1h)"
if [ -n "$commands_file" ]; then
  [ ${#commands[@]} -eq 0 ] || fail "give the commands after -- or in --commands FILE, not both"
  [ -f "$commands_file" ] && [ -r "$commands_file" ] || fail "--commands $commands_file: no such readable file"
  mapfile -t commands < <(sed 's/\r$//; /^[[:space:]]*#/d; /^[[:space:]]*$/d' "$commands_file")
  [ ${#commands[@]} -gt 0 ] || fail "--commands $commands_file holds no command"
fi
[ ${#commands[@]} -gt 0 ] || commands=("lockstep topology --out topology.json")
for line in "${commands[@]}"; do
  [ -n "${line//[[:space:]]/}" ] || fail "an empty command line after --"
  case "$line" in *$'\n'*) fail "a command line holds a newline: give one line each" ;; esac
done
[ -z "$bundle" ] || [ -f "$bundle" ] || fail "--bundle $bundle: no such file"
[ -n "$bundle" ] || [ "$arch" = "$(uname -m)" ] ||
  fail "the $topology machine is $arch: give --bundle FILE, a lockstep bundle built for $arch"
[ -n "$out" ] || out="build/emulated/$topology-$(date -u +%Y%m%dT%H%M%SZ)"
if [ -e "$out" ] && { [ ! -d "$out" ] || [ -n "$(ls -A "$out")" ]; }; then
  fail "--out $out exists and is not an empty directory"
fi
existing=$(dirname "$out")
while [ ! -e "$existing" ]; do existing=$(dirname "$existing"); done
[ -d "$existing" ] && [ -w "$existing" ] || fail "--out $out: $existing cannot be written"

# ---- what the machine needs
case "$arch" in
  x86_64) debian_arch=amd64 qemu=qemu-system-x86_64 qemu_package=qemu-system-x86 elf_machine='X86-64' ;;
  aarch64) debian_arch=arm64 qemu=qemu-system-aarch64 qemu_package=qemu-system-arm elf_machine='AArch64' ;;
esac
command -v "$qemu" >/dev/null ||
  fail "$qemu is missing (Debian's $qemu_package: scripts/setup.sh --emulated installs it)"
for tool in busybox apt-get apt-cache dpkg-deb readelf sha256sum base64; do
  command -v "$tool" >/dev/null || fail "$tool is missing (scripts/setup.sh --emulated installs what the machines need)"
done
readelf -l "$(command -v busybox)" | grep -q 'program interpreter' &&
  fail "this machine's busybox is not Debian's busybox-static (scripts/setup.sh --emulated installs it)"

work=$(mktemp -d)
partial=""  # $out.partial, while the machine runs
trap 'rm -rf "$work" ${partial:+"$partial"}' EXIT
quietly() {  # a step whose output is noise unless it fails
  "$@" >"$work/step.log" 2>&1 || { cat "$work/step.log" >&2; return 1; }
}

# A Debian package of the guest's architecture, fetched once into the cache:
# sets `fetched` to the directory its kernel or busybox was extracted into.
fetch_package() {
  fetched="$cache/$debian_arch/$1"
  [ -f "$fetched/.extracted" ] && return 0
  mkdir -p "$fetched"
  (cd "$fetched" && quietly apt-get download -q "$1:$debian_arch") ||
    fail "apt-get download $1:$debian_arch failed (is Debian's archive reachable? for arm64, scripts/setup.sh --emulated adds the architecture)"
  dpkg-deb --fsys-tarfile "$fetched"/*.deb | tar -x -C "$fetched" --wildcards './boot/vmlinuz-*' './bin/busybox' 2>/dev/null || true
  rm -f "$fetched"/*.deb
  # Either one: ls of both fails when one is absent, as it always is.
  compgen -G "$fetched/boot/vmlinuz-*" >/dev/null || [ -x "$fetched/bin/busybox" ] ||
    fail "$1:$debian_arch holds neither a kernel (boot/vmlinuz-*) nor bin/busybox"
  touch "$fetched/.extracted"
}

# The kernel: Debian's current linux-image-<version>-<arch> (what the
# linux-image-<arch> metapackage names), else the newest in the cache.
kernel_package=$(apt-cache depends "linux-image-$debian_arch:$debian_arch" 2>/dev/null |
  awk '/Depends: linux-image-[0-9]/ { sub(":.*", "", $2); print $2; exit }')
if [ -n "$kernel_package" ]; then
  fetch_package "$kernel_package"
  kernel=$(ls "$fetched"/boot/vmlinuz-* 2>/dev/null | head -n 1)
else
  kernel=$(ls -t "$cache/$debian_arch"/linux-image-*/boot/vmlinuz-* 2>/dev/null | head -n 1)
fi
[ -n "$kernel" ] && [ -f "$kernel" ] ||
  fail "no $debian_arch kernel: apt does not know linux-image-$debian_arch:$debian_arch (scripts/setup.sh --emulated adds the architecture and updates apt) and $cache holds none"

# busybox for the guest: this machine's own (busybox-static) when the guest
# is of its architecture, Debian's busybox-static for the guest's otherwise.
if [ "$arch" = "$(uname -m)" ]; then
  busybox=$(command -v busybox)
else
  fetch_package busybox-static
  busybox="$fetched/bin/busybox"
fi
[ -f "$busybox" ] || fail "no busybox-static for $debian_arch in $cache"

# The bundle: given, or the release preset's (x86_64 only).
if [ -z "$bundle" ]; then
  echo "emulated-machine: no --bundle: building one (scripts/bundle.sh, the release preset)" >&2
  scripts/bundle.sh --out "$work/bundle.tar.gz" >&2 || fail "scripts/bundle.sh failed"
  bundle="$work/bundle.tar.gz"
fi

# ---- the initramfs: busybox, the bundle at /opt/lockstep, what it loads from
# outside the bundle (a glibc-dynamic bundle's loader and glibc libraries, at
# the paths its binary names; nothing for a static one), the init and the
# commands.
root="$work/root"
mkdir -p "$root/bin" "$root/opt" "$root/proc" "$root/sys" "$root/dev" "$root/tmp" "$root/etc/emulated-machine"
tar -xzf "$bundle" -C "$root/opt" 2>/dev/null || fail "--bundle $bundle is not a tar.gz"
top=$(ls "$root/opt")
[ "$(wc -l <<<"$top")" = 1 ] && [ -f "$root/opt/$top/bin/lockstep" ] ||
  fail "--bundle $bundle holds no <name>/bin/lockstep (scripts/bundle.sh makes one)"
mv "$root/opt/$top" "$root/opt/lockstep"
binary="$root/opt/lockstep/bin/lockstep"
readelf -h "$binary" | grep -q "Machine:.*$elf_machine" ||
  fail "--bundle $bundle is not built for $arch ($(readelf -h "$binary" | sed -n 's/ *Machine: *//p')): the $topology machine needs one that is"

# The directories where glibc for the guest's architecture is found on this
# machine (the native multiarch ones, or the cross toolchain's).
case "$arch" in
  x86_64) glibc_directories=(/lib/x86_64-linux-gnu /usr/lib/x86_64-linux-gnu /lib64) ;;
  aarch64) glibc_directories=(/usr/aarch64-linux-gnu/lib /lib/aarch64-linux-gnu /usr/lib/aarch64-linux-gnu /lib) ;;
esac
carried=()
carry() {  # carry FILE-ON-THIS-MACHINE PATH-IN-THE-GUEST
  [ -e "$root$2" ] && return 0
  mkdir -p "$root$(dirname "$2")"
  cp -L "$1" "$root$2"
  carried+=("$2")
}
interpreter=$(readelf -l "$binary" | sed -n 's/.*Requesting program interpreter: \(.*\)]/\1/p')
if [ -n "$interpreter" ]; then
  found=""
  for directory in "$(dirname "$interpreter")" "${glibc_directories[@]}"; do
    [ -f "$directory/$(basename "$interpreter")" ] && { found="$directory/$(basename "$interpreter")"; break; }
  done
  [ -n "$found" ] || fail "the bundle's binary needs $interpreter, which this machine has not for $arch (a static bundle needs nothing)"
  carry "$found" "$interpreter"
  # Every library named by the binary or by a library already carried or
  # bundled, that the bundle's lib/ does not hold: glibc's.
  pending=("$binary" "$root/opt/lockstep/lib"/*.so*)
  while [ ${#pending[@]} -gt 0 ]; do
    file="${pending[0]}"; pending=("${pending[@]:1}")
    [ -f "$file" ] || continue
    for needed in $(readelf -d "$file" 2>/dev/null | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
      [ "$needed" = "$(basename "$interpreter")" ] && continue
      [ -e "$root/opt/lockstep/lib/$needed" ] && continue
      [ -e "$root/lib/$needed" ] && continue
      found=""
      for directory in "${glibc_directories[@]}"; do
        [ -f "$directory/$needed" ] && { found="$directory/$needed"; break; }
      done
      [ -n "$found" ] || fail "the bundle needs $needed, which neither it nor this machine's $arch glibc holds"
      carry "$found" "/lib/$needed"
      pending+=("$root/lib/$needed")
    done
  done
fi

cp "$busybox" "$root/bin/busybox"
cp scripts/emulated-machine-init.sh "$root/init"
chmod 755 "$root/init" "$root/bin/busybox"
printf '%s\n' "${commands[@]}" >"$root/etc/emulated-machine/commands"
# The commands end by this uptime, leaving the rest of the bound for booting
# (counted in the uptime) and for sending the files back.
margin=$((timeout_s / 10 > 20 ? timeout_s / 10 : 20))
echo "deadline=$((timeout_s - margin))" >"$root/etc/emulated-machine/settings"
(cd "$root" && find . | LC_ALL=C sort | busybox cpio -o -H newc 2>/dev/null) >"$work/initramfs.cpio" ||
  fail "busybox cpio could not make the initramfs"

# ---- the machine
cpu_count=${smp%%,*}
memory_mib=$(( ${memory%G} * 1024 ))
# thread=multi: a host thread a vCPU. One host thread for all (thread=single)
# ran c2c faster (a PAUSE hands the thread to the next vCPU), but stalled the
# 16-thread steps as often, and once calibrated the guest's TSC at 351 MHz
# instead of 2600 (its clock then ran 7 times fast); -icount kept the guest
# from booting (sleep=off) or made its steps take seconds (shift=auto).
qemu_arguments=(-nodefaults -display none -no-reboot -accel tcg,thread=multi
                -smp "$smp" -m "${memory_mib}M" -kernel "$kernel" -initrd "$work/initramfs.cpio"
                -serial stdio -monitor none)
if [ "$arch" = x86_64 ]; then
  # vendor=GenuineIntel: QEMU gives AMD's families no SMT ("This family of
  # AMD CPU doesn't support hyperthreading"), and with it the guest's clock
  # reads cost 2.4 us.
  qemu_arguments+=(-machine q35 -cpu max,vendor=GenuineIntel)
  console=ttyS0
else
  qemu_arguments+=(-machine virt,gic-version=3 -cpu neoverse-n1)
  console=ttyAMA0
fi
if [ "$nodes" != - ]; then
  IFS=/ read -r -a node_cpus <<<"$nodes"
  node_mib=$((memory_mib / ${#node_cpus[@]}))
  for index in "${!node_cpus[@]}"; do
    qemu_arguments+=(-object "memory-backend-ram,id=m$index,size=${node_mib}M"
                     -numa "node,nodeid=$index,cpus=${node_cpus[$index]},memdev=m$index")
  done
fi
# panic=-1: a guest whose init fails ends at once instead of at the timeout;
# no_timer_check: an emulated IO-APIC's timer can miss the kernel's check
# (a guest panicked so, "IO-APIC + timer doesn't work!").
qemu_arguments+=(-append "console=$console quiet panic=-1 no_timer_check")

partial="$out.partial"
rm -rf "$partial"
mkdir -p "$partial" || fail "--out $out: cannot make $partial"
{
  echo "topology: $topology ($shape)"
  echo "arch: $arch; cpus: $cpu_count; nodes: $nodes; memory: $memory; timeout: ${timeout_s}s"
  echo "kernel: $kernel"
  echo "busybox: $busybox"
  echo "bundle: $bundle ($top)"
  echo "carried from this machine: ${carried[*]:-nothing (a static bundle)}"
  echo "qemu: $qemu ${qemu_arguments[*]}"
} >"$partial/machine.txt"

echo "emulated-machine: booting $topology ($cpu_count $arch CPUs: $shape), bound ${timeout_s}s; the console goes to $out/console.log" >&2
started=$(date +%s)
set +e
timeout --kill-after=10 "$timeout_s" "$qemu" "${qemu_arguments[@]}" </dev/null 2>"$work/qemu.stderr" |
  tr -d '\r' | tee "$partial/console.log" | grep --line-buffered '^emulated: ' >&2
qemu_status=${PIPESTATUS[0]}
set -e
wall=$(($(date +%s) - started))

# ---- the files back
finish_failed() {
  rm -rf "$out"
  mkdir -p "$out"
  mv "$partial/console.log" "$out/console.log"
  [ -s "$work/qemu.stderr" ] && cat "$work/qemu.stderr" >"$out/qemu.stderr"
  rm -rf "$partial"
  echo "emulated-machine: $1 (after ${wall}s; the console is in $out/console.log)" >&2
  exit 3
}
header=$(grep -m 1 '^==lockstep-emulated-files sha256 ' "$partial/console.log" || true)
if [ -z "$header" ] || ! grep -q '^==lockstep-emulated-files end==$' "$partial/console.log"; then
  if [ "$qemu_status" = 124 ] || [ "$qemu_status" = 137 ]; then
    finish_failed "the $topology machine did not finish within ${timeout_s}s"
  fi
  [ -s "$work/qemu.stderr" ] && tail -n 5 "$work/qemu.stderr" >&2
  finish_failed "the $topology machine ended (qemu status $qemu_status) without sending its files back"
fi
sum=$(awk '{ print $3 }' <<<"$header")
sed -n '/^==lockstep-emulated-files sha256 /,/^==lockstep-emulated-files end==$/p' "$partial/console.log" |
  grep -E '^[A-Za-z0-9+/=]+$' | base64 -d >"$work/files.tar.gz" 2>/dev/null || true
[ "$(sha256sum "$work/files.tar.gz" | cut -d ' ' -f 1)" = "$sum" ] ||
  finish_failed "the files the $topology machine sent came back damaged (sha256 differs)"
tar -xzmf "$work/files.tar.gz" -C "$partial"
rm -rf "$out"
mv "$partial" "$out"

# ---- what ran
booted=$(sed -n 's/^emulated: booted in \([0-9.]*\) s.*/\1/p' "$out/console.log")
uptime=$(sed -n 's/^emulated: sent; powering off at \([0-9.]*\) s$/\1/p' "$out/console.log")
echo "wall: ${wall}s from start to power-off; the guest's init started ${booted:-?} s after its boot" >>"$out/machine.txt"
# The guest's clock: its uptime cannot exceed the host's wall time, unless
# the kernel calibrated its TSC wrong (dmesg: "tsc: Detected").
if [ -n "$uptime" ] && awk -v uptime="$uptime" -v wall="$wall" 'BEGIN { exit !(uptime > wall * 1.05 + 2) }'; then
  clock="the guest's clock ran fast ($uptime s of uptime in ${wall}s: $(grep -m 1 'tsc: Detected' "$out/guest-kernel/dmesg" | sed 's/^\[[^]]*\] //')); every time measured inside is off by that factor"
  echo "clock: $clock" >>"$out/machine.txt"
  echo "emulated-machine: $clock" >&2
fi
failed=0
for index in $(seq 1 ${#commands[@]}); do
  status=$(cat "$out/commands/$index.status" 2>/dev/null || echo "no status came back")
  if [ "$status" != 0 ]; then
    failed=$((failed + 1))
    echo "emulated-machine: command $index ($(cat "$out/commands/$index.command" 2>/dev/null || echo "${commands[$((index - 1))]}")): $status" >&2
  fi
done
if [ "$failed" -gt 0 ]; then
  echo "emulated-machine: $failed of ${#commands[@]} commands did not exit 0 on $topology (wall ${wall}s); files in $out" >&2
  exit 1
fi
echo "emulated-machine: every command exited 0 on $topology (${#commands[@]} commands, wall ${wall}s, booted in ${booted:-?} s); files in $out" >&2
