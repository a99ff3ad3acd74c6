#!/usr/bin/env bash
# The longest functions of the C++ and Python sources, longest first:
# "lines file:line name". Functions must stay under 100 lines in bench/,
# distributed/, reports/ and kernels/ (the default folders).
#
#   scripts/longest-functions.sh [COUNT] [FOLDER...]     (default: 10 bench distributed reports kernels)
#   scripts/longest-functions.sh --over N [FOLDER...]    every function longer than N lines; exit 1 if any
#
# The second form is the CTest test function_length (tests/CMakeLists.txt),
# which holds the limit. Needs universal-ctags (Debian's universal-ctags),
# which knows where each function ends; a lambda counts as a function of its own.
set -euo pipefail
cd "$(dirname "$0")/.."
over=""
if [ "${1:-}" = "--over" ]; then
  over=${2:?"--over needs a line count"}
  [[ "$over" =~ ^[0-9]+$ ]] || { echo "longest-functions: --over takes a line count, not '$over'" >&2; exit 2; }
  shift 2
  count=""
else
  count=${1:-10}
  shift || true
fi
folders=("$@")
[ ${#folders[@]} -gt 0 ] || folders=(bench distributed reports kernels)
# No `ctags --version | grep -q` nor `| head` below: a reader that leaves
# early kills the writer with SIGPIPE, which pipefail makes the pipeline's
# failure (scripts/bundle.sh says where that bit).
if ! command -v ctags >/dev/null || [[ "$(ctags --version 2>/dev/null)" != *Universal* ]]; then
  echo "longest-functions: needs universal-ctags (apt-get install universal-ctags)" >&2
  exit 2
fi
lengths=$(ctags -R --languages=C++,Python --kinds-C++=f --kinds-Python=fm --fields=+ne -x \
                --_xformat='%{end} %{line} %{input} %{name}' "${folders[@]}" 2>/dev/null |
            awk '$1 ~ /^[0-9]+$/ { printf "%d %s:%d %s\n", $1 - $2 + 1, $3, $2, $4 }' | sort -rn)
if [ -z "$over" ]; then
  sed -n "1,${count}p" <<<"$lengths"
  exit 0
fi
too_long=$(awk -v limit="$over" '$1 > limit' <<<"$lengths")
if [ -n "$too_long" ]; then
  echo "longest-functions: functions longer than $over lines in ${folders[*]} (split them by job):" >&2
  echo "$too_long" >&2
  exit 1
fi
echo "longest-functions: no function in ${folders[*]} is longer than $over lines"
