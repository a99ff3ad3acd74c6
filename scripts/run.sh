#!/usr/bin/env bash
# The main job: install what is missing, build the release preset, and run
# the benchmark matrix (`lockstep run`, the default matrix for this machine).
# Arguments go to `lockstep run` (e.g. --quick, --sync futex_spin, --out FILE).
# The result JSON goes to results/<host>-<timestamp>.json unless --out says
# otherwise; the run's last line on stderr, and its summary, say where.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)" --target lockstep
exec build/release/bench/lockstep run "$@"
