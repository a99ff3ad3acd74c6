#!/usr/bin/env bash
# Wake-up latency of `lockstep delay` beside cyclictest's, under the same
# settings, one after the other (never at once: they would disturb each other).
#
#   bench/vs_cyclictest.sh [--period-us 1000] [--priority 80] [--cpu 1]
#                          [--duration-s 10] [--lockstep PATH] [--keep DIR]
#
# Both tools are measured the same way: one thread pinned to --cpu, under
# SCHED_FIFO at --priority, memory locked, each period started by
# clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, next) and its latency taken
# as now - next on CLOCK_MONOTONIC right after the sleep returns (cyclictest's
# definition; bench/delay_paced.hpp does the same). lockstep's thread then
# computes one RK4 step (one participant: --threads 1); cyclictest's does
# nothing. cyclictest runs with --default-system so that it does not pin
# /dev/cpu_dma_latency to 0 behind lockstep's back (lockstep does not touch
# it either), and with -d 0 so that its one thread's interval is --period-us.
# lockstep is confined to --cpu with taskset, so its compact placement puts
# the one participant there.
#
# Both distributions are summarised by the same rule (percentiles by linear
# interpolation between closest ranks, as platform/stats.hpp and numpy do)
# from the raw samples: lockstep's JSON summary, cyclictest's verbose (-v -N)
# per-period nanosecond latencies.
#
# Needs root (or CAP_SYS_NICE + CAP_IPC_LOCK) for SCHED_FIFO and mlock, and
# cyclictest (Debian's rt-tests: scripts/setup.sh --test installs it).
# Exit status: 0 on success, 2 on bad input or a missing tool.
set -euo pipefail

period_us=1000
priority=80
cpu=1
duration_s=10
lockstep=""
keep=""

die() { echo "vs_cyclictest: $*" >&2; exit 2; }

while [ $# -gt 0 ]; do
  case "$1" in
    --period-us) period_us="${2:-}"; shift 2 ;;
    --priority) priority="${2:-}"; shift 2 ;;
    --cpu) cpu="${2:-}"; shift 2 ;;
    --duration-s) duration_s="${2:-}"; shift 2 ;;
    --lockstep) lockstep="${2:-}"; shift 2 ;;
    --keep) keep="${2:-}"; shift 2 ;;
    -h|--help) sed -n '2,30p' "$0"; exit 0 ;;
    *) die "unknown option '$1' (see --help)" ;;
  esac
done

for value in "$period_us" "$priority" "$cpu" "$duration_s"; do
  [[ "$value" =~ ^[0-9]+$ ]] || die "'$value' is not a whole number"
done
[ "$period_us" -ge 10 ] || die "--period-us must be at least 10"
[ "$priority" -ge 1 ] && [ "$priority" -le 99 ] || die "--priority must be in 1..99"
[ "$duration_s" -ge 1 ] || die "--duration-s must be at least 1"

here="$(cd "$(dirname "$0")/.." && pwd)"
if [ -z "$lockstep" ]; then
  for candidate in "$here/build/release/bench/lockstep" "$here/build/dev/bench/lockstep"; do
    if [ -x "$candidate" ]; then lockstep="$candidate"; break; fi
  done
fi
[ -n "$lockstep" ] && [ -x "$lockstep" ] || die "no lockstep binary; build one (cmake --build --preset release) or give --lockstep PATH"
command -v cyclictest >/dev/null || die "cyclictest not found; run scripts/setup.sh --test (Debian package rt-tests)"
command -v taskset >/dev/null || die "taskset not found (Debian package util-linux)"
online_cpus=$(getconf _NPROCESSORS_ONLN)
[ "$cpu" -lt "$online_cpus" ] || die "--cpu $cpu is not online (CPUs 0..$((online_cpus - 1)))"
python=/usr/bin/python3
[ -x "$python" ] || python=python3

work="$(mktemp -d /tmp/vs-cyclictest.XXXXXX)"
cleanup() { if [ -z "$keep" ]; then rm -rf "$work"; fi; }
trap cleanup EXIT

periods=$(( duration_s * 1000000 / period_us ))
echo "vs_cyclictest: ${periods} periods of ${period_us} us on CPU ${cpu}, SCHED_FIFO ${priority}, memory locked" >&2

echo "vs_cyclictest: lockstep delay (${duration_s} s) ..." >&2
taskset -c "$cpu" "$lockstep" delay --threads 1 --pin compact --sync std_barrier --layout padded64 \
  --period "${period_us}us" --duration "${duration_s}s" --fifo "$priority" --mlock \
  --out "$work/lockstep.json" > "$work/lockstep.txt"

echo "vs_cyclictest: cyclictest (${duration_s} s) ..." >&2
cyclictest --threads=1 --affinity="$cpu" --priority="$priority" --interval="$period_us" --distance=0 \
  --loops="$periods" --mlockall --nsecs --verbose --default-system --clock=0 \
  > "$work/cyclictest.txt" 2> "$work/cyclictest.err" || die "cyclictest failed: $(tail -1 "$work/cyclictest.err")"

if [ -n "$keep" ]; then
  mkdir -p "$keep" && cp "$work"/* "$keep"/ && echo "vs_cyclictest: raw outputs kept in $keep" >&2
fi

"$python" - "$work/lockstep.json" "$work/cyclictest.txt" "$period_us" "$priority" "$cpu" "$duration_s" <<'PY'
import json, math, re, sys

lockstep_path, cyclictest_path, period_us, priority, cpu, duration_s = sys.argv[1:]

def percentile(sorted_values, fraction):
    # Linear interpolation between closest ranks (numpy's default, platform/stats.hpp's rule).
    rank = fraction * (len(sorted_values) - 1)
    low = math.floor(rank)
    high = min(low + 1, len(sorted_values) - 1)
    return sorted_values[low] + (rank - low) * (sorted_values[high] - sorted_values[low])

with open(lockstep_path) as f:
    document = json.load(f)
ours = document["wakeup_latency_ns"]

samples = []
line = re.compile(r"^\s*(\d+):\s+(\d+):\s+(\d+)\s*$")
with open(cyclictest_path) as f:
    for text in f:
        match = line.match(text)
        if match:
            samples.append(int(match.group(3)))
if not samples:
    sys.exit("vs_cyclictest: no samples in cyclictest's output")
samples.sort()
theirs = {"min": samples[0], "p50": percentile(samples, 0.5), "p99": percentile(samples, 0.99),
          "max": samples[-1], "count": len(samples)}

print(f"wake-up latency, period {period_us} us, CPU {cpu}, SCHED_FIFO {priority}, mlockall, {duration_s} s each")
print(f"{'us':<12} {'lockstep':>12} {'cyclictest':>12} {'lockstep/cyclictest':>20}")
for key, label in (("min", "min"), ("p50", "median"), ("p99", "p99"), ("max", "max")):
    a = ours[key] / 1e3
    b = theirs[key] / 1e3
    ratio = f"{a / b:.2f}" if b > 0 else "n/a"
    print(f"{label:<12} {a:>12.2f} {b:>12.2f} {ratio:>20}")
print(f"{'samples':<12} {ours['count']:>12} {theirs['count']:>12}")
median_gap = abs(ours["p50"] - theirs["p50"]) / theirs["p50"] if theirs["p50"] > 0 else float("nan")
verdict = "within" if median_gap <= 0.25 else "NOT within"
print(f"median difference: {100 * median_gap:.1f} % ({verdict} the issue's 25 %)")
print(f"lockstep deadline misses: {document['deadline_misses']} of {document['completion_ns']['count']} periods")
PY
