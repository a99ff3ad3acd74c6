#!/usr/bin/env bash
# The longest functions of the C++ and Python sources, longest first:
# "lines file:line name". Functions must stay under 100 lines in bench/,
# distributed/ and reports/ (the default folders).
#
#   scripts/longest-functions.sh [COUNT] [FOLDER...]     (default: 10 bench distributed reports)
#
# Needs universal-ctags (Debian's universal-ctags), which knows where each
# function ends; a lambda counts as a function of its own.
set -euo pipefail
cd "$(dirname "$0")/.."
count=${1:-10}
shift || true
folders=("$@")
[ ${#folders[@]} -gt 0 ] || folders=(bench distributed reports)
# No `ctags --version | grep -q` nor `| head` below: a reader that leaves
# early kills the writer with SIGPIPE, which pipefail makes the pipeline's
# failure (scripts/bundle.sh says where that bit).
if ! command -v ctags >/dev/null || [[ "$(ctags --version 2>/dev/null)" != *Universal* ]]; then
  echo "longest-functions: needs universal-ctags (apt-get install universal-ctags)" >&2
  exit 2
fi
ctags -R --languages=C++,Python --kinds-C++=f --kinds-Python=fm --fields=+ne -x \
      --_xformat='%{end} %{line} %{input} %{name}' "${folders[@]}" 2>/dev/null |
  awk '$1 ~ /^[0-9]+$/ { printf "%d %s:%d %s\n", $1 - $2 + 1, $3, $2, $4 }' |
  sort -rn | sed -n "1,${count}p"
