#!/usr/bin/env bash
# Wake-up latency of `lockstep delay` beside cyclictest's, under the same
# settings, interleaved over several rounds (never at once: they would
# disturb each other), with the ratios of the medians and of the p99s.
#
#   bench/vs_cyclictest.sh [--period-us 1000] [--priority 80] [--cpu 1]
#                          [--duration-s 5] [--rounds 3]
#                          [--dma-latency-us 0 | --no-dma-latency]
#                          [--defaults] [--lockstep PATH] [--keep DIR]
#
# Like for like (the default): both tools run one thread pinned to --cpu,
# under SCHED_FIFO at --priority, memory locked, with the same idle setting
# (/dev/cpu_dma_latency held at --dma-latency-us, 0 unless told, as both tools
# do by default; or left alone by both with --no-dma-latency), each period
# started by clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, next) and its
# latency taken as now - next right after the sleep returns (cyclictest's
# definition; bench/probes/paced.hpp does the same). lockstep's thread then
# computes one RK4 step (`--threads 1`, the like-for-like view); cyclictest's
# does nothing. cyclictest runs with -d 0 so that a second thread would keep
# the interval too (its verbose header prints interval + distance for thread
# 0, 1500 by default, but thread 0 runs at the interval: 995 loops in 1 s at
# the default 1000 us, rt-tests 2.4); lockstep
# is confined to --cpu with taskset, so its compact placement puts the one
# participant there.
#
# --defaults: each tool with its own defaults instead, only the length given:
# `lockstep delay` (the paper's model: 4 participants, std_barrier, 1 ms,
# SCHED_OTHER, /dev/cpu_dma_latency held at 0) and `cyclictest` (one thread,
# unpinned, SCHED_OTHER, its interval, /dev/cpu_dma_latency at 0); prints
# lockstep's idle line beside the ratios.
#
# Rounds alternate which tool goes first (odd rounds lockstep, even rounds
# cyclictest), so a drift of the machine's pace does not favour either. Each
# round gives a ratio lockstep / cyclictest of the medians and of the p99s;
# the summary is the median of the rounds' ratios with their min..max.
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
duration_s=5
rounds=3
dma_latency_us=0
hold_dma=1
defaults=0
lockstep=""
keep=""

die() { echo "vs_cyclictest: $*" >&2; exit 2; }

while [ $# -gt 0 ]; do
  case "$1" in
    --period-us) period_us="${2:-}"; shift 2 || die "--period-us needs a value" ;;
    --priority) priority="${2:-}"; shift 2 || die "--priority needs a value" ;;
    --cpu) cpu="${2:-}"; shift 2 || die "--cpu needs a value" ;;
    --duration-s) duration_s="${2:-}"; shift 2 || die "--duration-s needs a value" ;;
    --rounds) rounds="${2:-}"; shift 2 || die "--rounds needs a value" ;;
    --dma-latency-us) dma_latency_us="${2:-}"; shift 2 || die "--dma-latency-us needs a value" ;;
    --no-dma-latency) hold_dma=0; shift ;;
    --defaults) defaults=1; shift ;;
    --lockstep) lockstep="${2:-}"; shift 2 || die "--lockstep needs a value" ;;
    --keep) keep="${2:-}"; shift 2 || die "--keep needs a value" ;;
    -h|--help) sed -n '2,44p' "$0"; exit 0 ;;
    *) die "unknown option '$1' (see --help)" ;;
  esac
done

for value in "$period_us" "$priority" "$cpu" "$duration_s" "$rounds" "$dma_latency_us"; do
  [[ "$value" =~ ^[0-9]+$ ]] || die "'$value' is not a whole number"
done
[ "$period_us" -ge 10 ] || die "--period-us must be at least 10"
[ "$priority" -ge 1 ] && [ "$priority" -le 99 ] || die "--priority must be in 1..99"
[ "$duration_s" -ge 1 ] || die "--duration-s must be at least 1"
[ "$rounds" -ge 1 ] && [ "$rounds" -le 100 ] || die "--rounds must be in 1..100"

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
if [ "$hold_dma" = 1 ]; then
  lockstep_idle=(--dma-latency "${dma_latency_us}us")
  cyclictest_idle=(--latency="$dma_latency_us")
  idle_words="/dev/cpu_dma_latency held at ${dma_latency_us} us by both"
else
  lockstep_idle=(--no-dma-latency)
  cyclictest_idle=(--default-system)
  idle_words="/dev/cpu_dma_latency left alone by both"
fi

run_lockstep() {  # round
  if [ "$defaults" = 1 ]; then
    "$lockstep" delay --duration "${duration_s}s" --out "$work/lockstep-$1.json" > "$work/lockstep-$1.txt"
  else
    taskset -c "$cpu" "$lockstep" delay --threads 1 --pin compact --sync std_barrier --layout padded64 \
      --period "${period_us}us" --duration "${duration_s}s" --fifo "$priority" --mlock "${lockstep_idle[@]}" \
      --out "$work/lockstep-$1.json" > "$work/lockstep-$1.txt"
  fi
}
run_cyclictest() {  # round
  if [ "$defaults" = 1 ]; then
    # Its default interval (1000 us) for --duration-s.
    cyclictest --duration="${duration_s}" --nsecs --verbose --quiet \
      > "$work/cyclictest-$1.txt" 2> "$work/cyclictest-$1.err" ||
      die "cyclictest failed: $(tail -1 "$work/cyclictest-$1.err")"
  else
    cyclictest --threads=1 --affinity="$cpu" --priority="$priority" --interval="$period_us" --distance=0 \
      --loops="$periods" --mlockall --nsecs --verbose --quiet --clock=0 "${cyclictest_idle[@]}" \
      > "$work/cyclictest-$1.txt" 2> "$work/cyclictest-$1.err" ||
      die "cyclictest failed: $(tail -1 "$work/cyclictest-$1.err")"
  fi
}

if [ "$defaults" = 1 ]; then
  echo "vs_cyclictest: each tool with its defaults, ${duration_s} s each, ${rounds} rounds" >&2
else
  echo "vs_cyclictest: ${periods} periods of ${period_us} us on CPU ${cpu}, SCHED_FIFO ${priority}, memory locked, ${idle_words}, ${rounds} rounds" >&2
fi
for round in $(seq 1 "$rounds"); do
  if [ $(( round % 2 )) = 1 ]; then order="lockstep cyclictest"; else order="cyclictest lockstep"; fi
  for tool in $order; do
    echo "vs_cyclictest: round ${round}: ${tool} (${duration_s} s) ..." >&2
    "run_$tool" "$round"
  done
done

if [ -n "$keep" ]; then
  mkdir -p "$keep" && cp "$work"/* "$keep"/ && echo "vs_cyclictest: raw outputs kept in $keep" >&2
fi

"$python" - "$work" "$rounds" "$defaults" "$period_us" "$priority" "$cpu" "$duration_s" "$idle_words" <<'PY'
import json, math, re, statistics, sys

work, rounds, defaults, period_us, priority, cpu, duration_s, idle_words = sys.argv[1:]
rounds = int(rounds)
defaults = defaults == "1"

def percentile(sorted_values, fraction):
    # Linear interpolation between closest ranks (numpy's default, platform/stats.hpp's rule).
    rank = fraction * (len(sorted_values) - 1)
    low = math.floor(rank)
    high = min(low + 1, len(sorted_values) - 1)
    return sorted_values[low] + (rank - low) * (sorted_values[high] - sorted_values[low])

line = re.compile(r"^\s*(\d+):\s+(\d+):\s+(\d+)\s*$")
rows = []
idle_line = ""
for round_index in range(1, rounds + 1):
    with open(f"{work}/lockstep-{round_index}.json") as f:
        ours = json.load(f)["wakeup_latency_ns"]
    with open(f"{work}/lockstep-{round_index}.txt") as f:
        for text in f:
            if text.startswith("idle: "):
                idle_line = text.strip()
    samples = []
    with open(f"{work}/cyclictest-{round_index}.txt") as f:
        for text in f:
            match = line.match(text)
            if match:
                samples.append(int(match.group(3)))
    if not samples:
        sys.exit(f"vs_cyclictest: no samples in cyclictest's output of round {round_index}")
    samples.sort()
    theirs = {"min": samples[0], "p50": percentile(samples, 0.5), "p99": percentile(samples, 0.99),
              "max": samples[-1], "count": len(samples)}
    rows.append((round_index, ours, theirs))

if defaults:
    print(f"wake-up latency, each tool with its defaults, {duration_s} s each, {rounds} rounds interleaved")
else:
    print(f"wake-up latency, period {period_us} us, CPU {cpu}, SCHED_FIFO {priority}, mlockall, {idle_words}, "
          f"{duration_s} s each, {rounds} rounds interleaved")
print(f"{'round':<6} {'tool':<11} {'min':>9} {'median':>9} {'p99':>9} {'max':>10} {'samples':>8}   us")
median_ratios, p99_ratios = [], []
for round_index, ours, theirs in rows:
    for tool, d in (("lockstep", ours), ("cyclictest", theirs)):
        print(f"{round_index:<6} {tool:<11} {d['min'] / 1e3:>9.2f} {d['p50'] / 1e3:>9.2f} {d['p99'] / 1e3:>9.2f} "
              f"{d['max'] / 1e3:>10.2f} {d['count']:>8}")
    median_ratios.append(ours["p50"] / theirs["p50"])
    p99_ratios.append(ours["p99"] / theirs["p99"])
print()
print(f"{'round':<6} {'median ratio':>13} {'p99 ratio':>10}   lockstep / cyclictest")
for (round_index, _, _), m, p in zip(rows, median_ratios, p99_ratios):
    print(f"{round_index:<6} {m:>13.3f} {p:>10.3f}")
def summary(values):
    return f"{statistics.median(values):.3f} (min {min(values):.3f}, max {max(values):.3f}, {len(values)} rounds)"
print(f"median ratio: {summary(median_ratios)}")
print(f"p99 ratio:    {summary(p99_ratios)}")
if idle_line:
    print(f"lockstep's {idle_line}")
PY
