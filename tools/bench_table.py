"""Prints the headline figures of every results/bench_*.json as one table.

Each benchmark writes {"headline": [{"figure": ..., "value": ..., "unit": ..., "goal": ...}], ...}.
"""
import json
import sys
from pathlib import Path


def main(results_dir: Path) -> int:
    rows = []
    for path in sorted(results_dir.glob("bench_*.json")):
        data = json.loads(path.read_text())
        for row in data.get("headline", []):
            rows.append((path.stem, str(row["figure"]), f'{row["value"]:.4g}' if isinstance(row["value"], (int, float)) else str(row["value"]),
                         str(row.get("unit", "")), str(row.get("goal", ""))))
    if not rows:
        print("bench: no results/bench_*.json found")
        return 1
    header = ("benchmark", "figure", "value", "unit", "goal")
    widths = [max(len(r[i]) for r in rows + [header]) for i in range(len(header))]
    for r in [header] + rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)))
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1])))
