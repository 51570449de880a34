#!/usr/bin/env bash
# Runs every benchmark of the package (scripts/bench_*, then sim_to_real), each writing its
# results/*.json with its provenance, prints one table of the headline figures and regenerates
# docs/results.md and the README's table (tools/gen_docs.py). Expects the catkin workspace sourced.
#   BENCH="bench_task bench_sim" tools/bench.sh   runs those alone
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mkdir -p "$here/results"
status=0
for bench in ${BENCH:-$(cd "$here/scripts" && ls bench_* sim_to_real)}; do
  bench=$here/scripts/$bench
  [ -x "$bench" ] || { echo "bench: no scripts/$(basename "$bench")" >&2; status=1; continue; }
  echo "== $(basename "$bench")"
  "$bench" --out "$here/results" || { echo "bench: $(basename "$bench") failed" >&2; status=1; }
done
python3 "$here/tools/bench_table.py" "$here/results"
python3 "$here/tools/gen_docs.py" || status=1
exit $status
