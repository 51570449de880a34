"""Benchmark: large floors. The planners' travel table and the C++ cores at building size, beside the lab.

    rosrun marl_mrta bench_floor [--out results] [--repeats 3]

Floors: the lab (8 × 6 m at 0.05 m), a 60 × 60 m floor of rooms at 0.05 m (the generator's
`rooms` layout), and a 30 × 50 m warehouse at 0.03 m drawn here (shelving rows as unknown space,
`mode: trinary`, `free_thresh: 0.1`, as a SLAM map of one leaves them). On each, a scenario of 16
robots × 32 tasks drawn by the generator, then:
- the travel table (48 nodes, every leg along navfn's path on move_base's global costmap): wall
  time, the best of `--repeats` (the goal: ≤ 10 s on both large floors);
- the simulator core with 16 robots (bench_sim_core: real-time factor per CPU second, lidar on);
- navigation's cores (bench_nav_core with config/nav: a plan, a full global costmap update, an
  update from a scan, a DWA cycle).
Writes <out>/bench_floor.json (headline first, tools/gen_docs.py).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from marl_mrta.common.paths import default_config_path, package_root
from marl_mrta.common.results import write_result
from marl_mrta.env.settings import load_embedded_settings
from marl_mrta.model.generator import ScenarioRequest, generate_scenarios
from marl_mrta.model.scenario import load_scenario
from marl_mrta.model.travel import build_travel_table, scenario_poses, scenario_travel_model

ROBOTS, TASKS = 16, 32
TRAVEL_GOAL_S = 10.0


def warehouse_map(directory: Path) -> Path:
    """A 30 × 50 m warehouse at 0.03 m: walls, three columns of shelving rows as unknown space."""
    resolution, width_m, height_m = 0.03, 30.0, 50.0
    width, height = int(round(width_m / resolution)), int(round(height_m / resolution))
    image = np.full((height, width), 254, np.uint8)
    image[:4, :], image[-4:, :], image[:, :4], image[:, -4:] = 0, 0, 0, 0
    for row in range(8):
        top = height - int((5.0 + 5.5 * row) / resolution)
        for column in range(3):
            left = int((3.0 + 9.0 * column) / resolution)
            image[top - int(1.2 / resolution):top, left:left + int(6.0 / resolution)] = 205
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "warehouse.pgm").write_bytes(b"P5\n%d %d\n255\n" % (width, height) + image.tobytes())
    (directory / "warehouse.yaml").write_text("image: warehouse.pgm\nresolution: 0.03\norigin: [0.0, 0.0, 0.0]\n"
                                              "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.1\nmode: trinary\n")
    return directory / "warehouse.yaml"


def floor_scenarios(work: Path) -> Dict[str, Path]:
    """The lab, the 60 m floor of rooms and the warehouse, each with a 16 × 32 scenario."""
    model = load_embedded_settings().travel
    floors = {"lab": dict(layout="lab"), "rooms_60x60": dict(layout="rooms", width=60.0, height=60.0),
              "warehouse_30x50": dict(layout=str(warehouse_map(work / "maps")))}
    out: Dict[str, Path] = {}
    for name, layout in floors.items():
        request = ScenarioRequest(n_robots=ROBOTS, n_tasks=TASKS, max_leg=10_000.0, name=name, **layout)
        scenario = generate_scenarios(1, 0, work / name, request, model,
                                      keep=("n_robots", "n_tasks", "layout", "width", "height"))[0]
        out[name] = Path(scenario.source)
    return out


def cores(binary: str, *args: str) -> List[Dict[str, Any]]:
    """A C++ benchmark core's JSON (a list, or one object a line)."""
    done = subprocess.run([_binary(binary), *args], capture_output=True, text=True, check=True)
    text = done.stdout.strip()
    return json.loads(text) if text.startswith("[") else [json.loads(line) for line in text.splitlines() if line]


def _binary(name: str) -> str:
    from roslib.packages import find_node   # the workspace's build of the C++ benchmark cores
    found = find_node("marl_mrta", name)
    if not found:
        raise FileNotFoundError(f"{name}: not built (make build)")
    return found[0]


def bench(repeats: int, log=print) -> Dict[str, Any]:
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_floor_") as tmp:
        work = Path(tmp)
        for name, path in floor_scenarios(work).items():
            scenario = load_scenario(path)
            seconds = []
            model = scenario_travel_model(scenario, load_embedded_settings().travel)
            for _ in range(repeats):   # planned anew each time: the process's table cache left out
                started = time.perf_counter()
                build_travel_table(str(Path(scenario.map_path).resolve()), scenario_poses(scenario), model)
                seconds.append(time.perf_counter() - started)
            map_yaml = str(scenario.map_path)
            sim = cores("bench_sim_core", map_yaml, str(ROBOTS))[0]
            nav = cores("bench_nav_core", str(default_config_path("nav")), map_yaml)[0]
            row = {"floor": name, "cells": nav["cells"], "travel_table_s": min(seconds),
                   "sim_rtf_cpu_16": sim["rtf_cpu"], "plan_ms": nav["planning"]["mean_ms"],
                   "global_costmap_full_update_ms": nav["global_costmap_full_update"]["mean_ms"],
                   "global_costmap_scan_update_ms": nav["global_costmap_update_with_scan"]["mean_ms"],
                   "local_costmap_update_ms": nav.get("local_costmap_update", {}).get("mean_ms"),
                   "dwa_cycle_ms": nav.get("dwa_cycle", {}).get("mean_ms")}
            rows.append(row)
            log(f"{name} ({row['cells'][0]} x {row['cells'][1]} cells): travel table {row['travel_table_s']:.2f} s, "
                f"simulator {row['sim_rtf_cpu_16']:.0f} x real time per CPU s (16 robots), plan {row['plan_ms']:.2f} ms, "
                f"costmap update from a scan {row['global_costmap_scan_update_ms']:.3f} ms")
    headline = []
    for row in rows:
        large = row["floor"] != "lab"
        headline += [
            {"figure": f"{row['floor']}: travel table, {ROBOTS} robots x {TASKS} tasks", "unit": "s",
             "value": round(row["travel_table_s"], 2), "goal": f"<= {TRAVEL_GOAL_S:g}" if large else ""},
            {"figure": f"{row['floor']}: simulator core, 16 robots, lidar on", "unit": "x",
             "value": round(row["sim_rtf_cpu_16"], 0), "goal": ""},
            {"figure": f"{row['floor']}: global costmap update from a scan", "unit": "ms",
             "value": round(row["global_costmap_scan_update_ms"], 4), "goal": ""},
            {"figure": f"{row['floor']}: a global plan (navfn)", "unit": "ms", "value": round(row["plan_ms"], 3),
             "goal": ""},
        ]
    return {"headline": headline, "rows": rows, "settings": {"repeats": repeats, "robots": ROBOTS, "tasks": TASKS}}


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="bench_floor", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=package_root() / "results", help="directory of bench_floor.json")
    parser.add_argument("--repeats", type=int, default=3, help="travel tables timed per floor (default 3)")
    args = parser.parse_args(argv)
    result = bench(args.repeats, log=lambda line: print(line, file=sys.stderr, flush=True))
    write_result(args.out / "bench_floor.json", result)
    for row in result["headline"]:
        print(f"{row['figure']}: {row['value']} {row['unit']} (goal {row['goal'] or '-'})")
    return 0
