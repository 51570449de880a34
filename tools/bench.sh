#!/usr/bin/env bash
# Runs every benchmark of the package (scripts/bench_*), each writing results/bench_*.json,
# then prints one table of the headline figures. Expects the catkin workspace sourced.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mkdir -p "$here/results"
status=0
for bench in "$here"/scripts/bench_*; do
  [ -x "$bench" ] || continue
  echo "== $(basename "$bench")"
  "$bench" --out "$here/results" || { echo "bench: $(basename "$bench") failed" >&2; status=1; }
done
python3 "$here/tools/bench_table.py" "$here/results"
exit $status
