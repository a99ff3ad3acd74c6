#!/usr/bin/env bash
# Regenerates reports/samples/ from real runs on this machine, so that a new
# user can compare their own machine with it at once:
#
#   reports/make_samples.sh            build the release preset, then run everything (about 5 minutes)
#   LOCKSTEP=path/to/lockstep reports/make_samples.sh     use that binary instead of building
#
# What it writes (each file replaced only when its command succeeded):
#   samples/run.json           `lockstep run` (the default matrix)
#   samples/pair-a.json        a focused run made for comparing: a few primitives at
#                              2 threads pinned, with enough repetitions (REPETITIONS,
#                              default 12) for a Mann-Whitney U test to reach
#                              significance after Holm's correction (5 against 5
#                              repetitions never can: the smallest p is 0.008), run
#                              with Google Benchmark's random interleaving so that each
#                              entry's repetitions are spread over the whole run: a slow
#                              drift of the machine during the run then lands in every
#                              entry's spread instead of shifting the entries measured
#                              while it lasted
#   samples/pair-b.json        the same run again, except that the entries of one
#                              primitive (LOSER, default std_barrier) come from a run
#                              made while a CPU-bound process competes for the cores:
#                              real measurements, spliced so that exactly that
#                              primitive is forced to lose (the compare acceptance check)
#   samples/c2c.json           `lockstep c2c --out`
#   samples/delay.json         `lockstep delay --out --compare-pinning`
#   samples/verify.csv         `lockstep verify --csv`
#   samples/compare.txt        `lockstep compare pair-a.json pair-b.json`
#   samples/report/            `lockstep report` on all of them (report.html, report.md, figures/)
#
# Measure on a quiet machine: every other job competes with the benchmark.
set -euo pipefail
cd "$(dirname "$0")/.."

samples=reports/samples
loser=${LOSER:-std_barrier}
delay_seconds=${DELAY_SECONDS:-10}
repetitions=${REPETITIONS:-12}
# The focused pair: the suite's contender, the C++ baseline, glibc's barrier
# and a dataflow channel, each on its best layout family, 2 threads pinned.
pair_syncs="futex_spin,std_barrier,pthread_barrier,seqlock"
pair=(--layout "padded64,per_thread" --threads 2 --pin compact --repetitions "$repetitions")
# The focused runs shuffle their repetitions (Google Benchmark's random interleaving).
interleaving=(--interleave)

fail() { echo "make_samples: $*" >&2; exit 1; }

if [ -n "${LOCKSTEP:-}" ]; then
  lockstep=$LOCKSTEP
else
  cmake --preset release >/dev/null || fail "cmake --preset release failed"
  cmake --build --preset release -j 2 --target lockstep || fail "building lockstep (release) failed"
  lockstep=build/release/bench/lockstep
fi
[ -x "$lockstep" ] || fail "no lockstep binary at $lockstep"
[ -x /usr/bin/python3 ] || fail "/usr/bin/python3 is missing: run scripts/setup.sh"
# A binary from before `lockstep run --interleave`: pass Google Benchmark's own flag.
if ! "$lockstep" help run 2>/dev/null | grep -q -- "--interleave"; then
  interleaving=(-- --benchmark_enable_random_interleaving=true)
fi

# Every command this script needs must exist in this binary (`lockstep help X`
# fails for a command that is not registered yet).
for command in run c2c delay verify compare report; do
  "$lockstep" help "$command" >/dev/null 2>&1 ||
    fail "\`lockstep $command\` is not available in $lockstep yet (is its issue merged? rebuild after \`git merge main\`)"
done

work=$(mktemp -d "${TMPDIR:-/tmp}/lockstep-samples-XXXXXX")
hog_pid=""
cleanup() {
  if [ -n "$hog_pid" ]; then kill "$hog_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

step() { echo "make_samples: $*" >&2; }

step "lockstep run (default matrix)"
"$lockstep" run --out "$work/run.json" || fail "lockstep run failed"

step "lockstep run, the focused pair (a)"
"$lockstep" run --sync "$pair_syncs" "${pair[@]}" --out "$work/pair-a.json" "${interleaving[@]}" >/dev/null || fail "lockstep run (pair a) failed"

step "lockstep run, the focused pair again (b)"
"$lockstep" run --sync "$pair_syncs" "${pair[@]}" --out "$work/rerun.json" "${interleaving[@]}" >/dev/null || fail "lockstep run (pair b) failed"

step "lockstep run --sync $loser with a competing CPU-bound process (the forced loser)"
/usr/bin/python3 -c 'while True: pass' &
hog_pid=$!
"$lockstep" run --sync "$loser" "${pair[@]}" --out "$work/loser.json" "${interleaving[@]}" >/dev/null ||
  fail "lockstep run --sync $loser failed"
kill "$hog_pid" 2>/dev/null || true
wait "$hog_pid" 2>/dev/null || true
hog_pid=""

step "splicing: rerun with the $loser entries of the loaded run"
/usr/bin/python3 - "$work/rerun.json" "$work/loser.json" "$loser" "$work/pair-b.json" <<'PY'
import json, sys
rerun_path, loser_path, loser, out_path = sys.argv[1:]
rerun = json.load(open(rerun_path))
loaded = json.load(open(loser_path))
def is_loser(entry):
    segments = str(entry.get("run_name") or entry.get("name", "")).split("/")
    return f"sync:{loser}" in segments
kept = [entry for entry in rerun["benchmarks"] if not is_loser(entry)]
spliced = [entry for entry in loaded["benchmarks"] if is_loser(entry)]
if not spliced:
    sys.exit(f"make_samples: the loaded run has no sync:{loser} entries")
rerun["benchmarks"] = kept + spliced
rerun["context"]["samples_note"] = (f"sync:{loser} entries measured while a CPU-bound process competed "
                                    "(forced loser); the rest is a plain rerun")
json.dump(rerun, open(out_path, "w"), indent=2)
PY

step "lockstep c2c"
"$lockstep" c2c --out "$work/c2c.json" || fail "lockstep c2c failed"

step "lockstep delay (${delay_seconds} s, pinned and unpinned)"
delay_arguments=(--out "$work/delay.json" --compare-pinning)
if "$lockstep" help delay 2>/dev/null | grep -q -- "--duration"; then
  delay_arguments+=(--duration "${delay_seconds}s")
fi
"$lockstep" delay "${delay_arguments[@]}" || fail "lockstep delay failed"

step "lockstep verify --csv"
"$lockstep" verify --csv "$work/verify.csv" >/dev/null || fail "lockstep verify failed"

step "lockstep compare"
status=0
"$lockstep" compare "$work/pair-a.json" "$work/pair-b.json" --fail-above 10 >"$work/compare.txt" 2>"$work/compare.err" || status=$?
[ "$status" -le 1 ] || fail "lockstep compare failed ($status): $(cat "$work/compare.err")"
cat "$work/compare.err" >>"$work/compare.txt"

# Publish: move everything into samples/ at once, labels as in the file names.
mkdir -p "$samples"
for name in run.json pair-a.json pair-b.json c2c.json delay.json verify.csv compare.txt; do
  mv "$work/$name" "$samples/$name"
done

step "lockstep report"
rm -rf "$samples/report"
"$lockstep" report "$samples/run.json" "$samples/c2c.json" "$samples/delay.json" "$samples/verify.csv" \
  --out "$samples/report" --title "lockstep samples: $(hostname)" || fail "lockstep report failed"

step "done: $samples (compare exit status $status: 1 means a combination was flagged slower beyond 10%; read compare.txt: only the $loser entries should be)"
