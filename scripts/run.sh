#!/usr/bin/env bash
# The main job: install what is missing, build the release preset, run the
# benchmark matrix (`lockstep run`, the default matrix for this machine) and
# write the HTML report beside its JSON.
# Arguments go to `lockstep run` (e.g. --quick, --sync futex_spin, --out FILE,
# --verbose). The JSON goes to results/<host>-<timestamp>.json unless --out
# says otherwise, the report to the same name with -report in place of .json
# (report.html inside); the run ends with its answer and both paths.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)" --target lockstep
lockstep=build/release/bench/lockstep

# Where the result goes: the user's --out, or a name chosen here (the same
# form lockstep run chooses: bench/results/result_file.cpp default_result_path).
out=""
previous=""
for argument in "$@"; do
  case "$argument" in
    --plan|--help|-h) exec "$lockstep" run "$@" ;;  # nothing measured, nothing to report
    --out=*) out="${argument#--out=}" ;;
  esac
  [ "$previous" = --out ] && out="$argument"
  previous="$argument"
done
arguments=("$@")
if [ -z "$out" ]; then
  # results/ is made here only when missing, and removed again if the run
  # leaves it empty (input refused, a failure, a signal): as `lockstep run`
  # does with its own default destination, a run that wrote nothing leaves
  # nothing behind.
  if [ ! -d results ]; then
    mkdir results
    trap 'rmdir results 2>/dev/null || true' EXIT
  fi
  out="results/$(hostname)-$(date -u +%Y%m%dT%H%M%SZ).json"
  arguments+=(--out "$out")
fi

"$lockstep" run "${arguments[@]}"
report="${out%.json}-report"
if "$lockstep" report "$out" --out "$report" >/dev/null; then
  echo "The report is written: $report/report.html (the answer first; open it in a browser)"
else
  echo "lockstep report could not write $report: the results are in $out" >&2
  exit 1
fi
