#!/bin/busybox sh
# The init of an emulated machine (scripts/emulated-machine.sh puts it at /init
# of the initramfs it boots). Runs inside the guest, with busybox alone:
#
#   1. mounts /proc, /sys, /dev and /tmp;
#   2. writes the guest kernel's own view of its topology to
#      /out/guest-kernel/ (topology.txt: every file under
#      /sys/devices/system/cpu/cpu*/topology/, each cache's level, type and
#      shared_cpu_list, each NUMA node's cpulist, one "path<TAB>content" line a
#      file; cpuinfo, cmdline, uname; dmesg at the end);
#   3. runs each line of /etc/emulated-machine/commands (a shell command line,
#      lockstep on the PATH) in /out/results, in order, each with its stdout,
#      stderr, exit status and seconds in /out/commands/<n>.*, stopping none
#      for another's failure; a command still running at the deadline the
#      host set (seconds of uptime) is ended and marked, the rest are not run;
#   4. sends /out back over the console: a gzipped tar in base64 between two
#      marker lines, the first carrying its sha256, with the kernel's console
#      messages silenced (they would break the lines; dmesg keeps them);
#   5. powers off (or, if that fails, exits: panic=-1 and qemu's -no-reboot
#      end the machine).
#
# Progress lines go to the console, each starting "emulated: ".

/bin/busybox --install -s /bin
export PATH=/opt/lockstep/bin:/bin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /tmp
exec </dev/null >/dev/console 2>&1

say() { echo "emulated: $*"; }
uptime_s() { cut -d ' ' -f 1 /proc/uptime; }

# deadline: uptime in seconds by which the commands must have ended, left for
# sending the files back before the host's own timeout.
. /etc/emulated-machine/settings
out=/out
mkdir -p "$out/guest-kernel" "$out/commands" "$out/results"

cpus=$(ls -d /sys/devices/system/cpu/cpu[0-9]* | wc -l)
nodes=$(ls -d /sys/devices/system/node/node[0-9]* 2>/dev/null | wc -l)
say "booted in $(uptime_s) s: $cpus CPUs, $nodes NUMA nodes, kernel $(uname -r) ($(uname -m))"

# The kernel's view: one line a file, "path<TAB>content" (each of these
# files is one line), in one grep: processes are dear under emulation, and
# three a file (some 2000) took 80 s on the 16-CPU machine.
cpu=/sys/devices/system/cpu
grep -s -H '' $cpu/cpu[0-9]*/topology/* $cpu/cpu[0-9]*/cache/index*/level $cpu/cpu[0-9]*/cache/index*/type \
    $cpu/cpu[0-9]*/cache/index*/shared_cpu_list $cpu/cpu[0-9]*/cache/index*/size \
    $cpu/cpu[0-9]*/cache/index*/coherency_line_size /sys/devices/system/node/node[0-9]*/cpulist \
    /sys/devices/system/node/node[0-9]*/distance $cpu/online $cpu/possible |
  sed 's/:/\t/' >"$out/guest-kernel/topology.txt"
cat /proc/cpuinfo >"$out/guest-kernel/cpuinfo"
cat /proc/cmdline >"$out/guest-kernel/cmdline"
uname -a >"$out/guest-kernel/uname"

# The commands, in order.
total=$(grep -c . /etc/emulated-machine/commands)
n=0
while IFS= read -r line; do
  [ -n "$line" ] || continue
  n=$((n + 1))
  printf '%s\n' "$line" >"$out/commands/$n.command"
  left=$(awk -v deadline="$deadline" -v now="$(uptime_s)" 'BEGIN { printf "%d", deadline - now }')
  if [ "$left" -le 0 ]; then
    echo "not run: the machine's time ran out" >"$out/commands/$n.status"
    say "[$n/$total] not run (the time ran out): $line"
    continue
  fi
  say "[$n/$total] $line"
  start=$(uptime_s)
  (cd "$out/results" && exec timeout -s TERM -k 10 "$left" sh -c "$line") \
    </dev/null >"$out/commands/$n.stdout" 2>"$out/commands/$n.stderr"
  status=$?
  end=$(uptime_s)
  seconds=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }')
  echo "$seconds" >"$out/commands/$n.seconds"
  # Ended by timeout (TERM, then KILL 10 s later) when it ran its whole share.
  if [ "$status" -ge 124 ] && awk -v a="$start" -v b="$end" -v left="$left" 'BEGIN { exit !(b - a >= left - 0.5) }'; then
    echo "timed out: ended at the machine's deadline (status $status)" >"$out/commands/$n.status"
    say "[$n/$total] timed out after $seconds s"
  else
    echo "$status" >"$out/commands/$n.status"
    say "[$n/$total] exit $status in $seconds s"
  fi
done </etc/emulated-machine/commands

dmesg >"$out/guest-kernel/dmesg"
say "commands done at $(uptime_s) s; sending the files"

# Back over the console, with the kernel's messages kept off it.
echo 1 >/proc/sys/kernel/printk
tar -czf /tmp/out.tar.gz -C "$out" .
sum=$(sha256sum /tmp/out.tar.gz | cut -d ' ' -f 1)
echo "==lockstep-emulated-files sha256 $sum bytes $(wc -c </tmp/out.tar.gz)=="
base64 /tmp/out.tar.gz
echo "==lockstep-emulated-files end=="
say "sent; powering off at $(uptime_s) s"
poweroff -f
