#!/usr/bin/env bash
# The main job: install what is missing, build the release preset, and run
# lockstep's default job. Arguments go to that job.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)"
exec build/release/bench/lockstep verify "$@"
