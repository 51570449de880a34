"""`bench_scale`: the reference's solvers and the baselines from 2 to 16 robots, 8 to 32 tasks.

Sizes: 2x8 and 4x8 (lab_2r, lab_4r), 6x16 (a generated 12 x 8 m map of rooms, three stages of
two-predecessor joins, 3 s service; written to a temporary directory), 8x16 and 16x32
(site_8r, site_16r). Per size:
- the reference as `evaluate` computes it (A* for the small teams, CP-SAT otherwise) and the
  CP-SAT path alone at 10 s and at 60 s of deterministic time per model: best makespan, lower
  bound, gap, wall seconds (the time to the optimum when it is proven);
- every method run by `evaluate` in a process of its own (random 20 episodes, the plans one;
  the reference's 10 s per model for `exact`): makespan, its ratio to the best known makespan
  and to the lower bound of the 60 s run, completion, peak memory (the process's maximum
  resident set, os.wait4).
Writes <out>/bench_scale.json ({"headline": [...], ...}, the format tools/bench_table.py prints);
the MAPPO figures and the ROS real-time factors of each size have their keys, filled elsewhere.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.common.paths import package_root
from marl_mrta.env.factory import make_env
from marl_mrta.env.settings import load_embedded_settings
from marl_mrta.model.generator import ScenarioRequest, generate_scenario

METHODS = ("random", "ga", "auction", "exact")
CPSAT_LIMITS = (10.0, 60.0)
EXACT_LIMIT = 10.0
MEMORY_GOAL_MB = 4096.0


def sizes(work: Path) -> List[Tuple[str, Path]]:
    """(size label, scenario file) from the smallest team to the largest."""
    scenarios = package_root() / "scenarios"
    generated = generate_scenario(ScenarioRequest(n_robots=6, n_tasks=16, layout="rooms", width=12.0, height=8.0,
                                                  dag="joins", stages=3, service_times=(3.0,), name="rooms_6r"),
                                  0, work, load_embedded_settings().travel)
    return [("2x8", scenarios / "lab_2r.xml"), ("4x8", scenarios / "lab_4r.xml"), ("6x16", generated.source),
            ("8x16", scenarios / "site_8r.xml"), ("16x32", scenarios / "site_16r.xml")]


def reference_run(scenario: Path, time_limit: float, cpsat_only: bool) -> Dict[str, Any]:
    """The reference on a scenario (CP-SAT alone: A* never chosen), its figures and wall time."""
    env = make_env(scenario, seed=0)
    settings = load_baseline_settings().with_cpsat(time_limit=time_limit)
    if cpsat_only:
        settings = replace(settings, astar_max_batch=0)
    instance = scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout)
    started = time.monotonic()
    reference = solve_reference(instance, settings)
    seconds = time.monotonic() - started
    return {**reference.as_dict(), "wall_seconds": seconds, "time_limit_per_model": time_limit,
            "time_to_optimum": seconds if reference.proven_optimal else None}


def evaluate_process(scenario: Path, method: str, out: Path) -> Dict[str, Any]:
    """`evaluate --method <method>` in a process of its own: its result document and peak memory."""
    argv = [sys.executable, str(package_root() / "scripts" / "evaluate"), "--method", method,
            "--scenario", str(scenario), "--episodes", "20" if method == "random" else "1", "--quiet",
            "--out", str(out)]
    argv += ["--time-limit", str(EXACT_LIMIT)] if method == "exact" else ["--no-exact"]
    started = time.monotonic()
    process = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    _, status, usage = os.wait4(process.pid, 0)
    seconds = time.monotonic() - started
    errors = process.stderr.read()
    process.stderr.close()
    if status != 0:
        raise RuntimeError(f"evaluate --method {method} on {scenario.name} failed: {errors.strip().splitlines()[-1:]}")
    summary = json.loads(out.read_text())["results"][0]["summary"]
    return {"makespan": summary["makespan_mean"], "makespan_sd": summary["makespan_sd"],
            "complete_pct": summary["complete_pct"], "logic_consistent_pct": summary["logic_consistent_pct"],
            "peak_memory_mb": usage.ru_maxrss / 1024.0, "seconds": seconds}


def bench_size(label: str, scenario: Path, work: Path) -> Dict[str, Any]:
    print(f"bench_scale: {label} ({scenario.name}) ...", file=sys.stderr)
    as_evaluated = reference_run(scenario, EXACT_LIMIT, cpsat_only=False)
    cpsat = {f"{limit:g}": reference_run(scenario, limit, cpsat_only=True) for limit in CPSAT_LIMITS}
    best = min([as_evaluated["best_makespan"]] + [c["best_makespan"] for c in cpsat.values()])
    lower = max([as_evaluated["lower_bound"]] + [c["lower_bound"] for c in cpsat.values()])
    methods = {}
    for method in METHODS:
        figures = evaluate_process(scenario, method, work / f"{label}_{method}.json")
        figures["ratio_to_best"] = figures["makespan"] / best
        figures["ratio_to_lower_bound"] = figures["makespan"] / lower if lower > 0 else None
        methods[method] = figures
    env = make_env(scenario, seed=0)
    return {"size": label, "scenario": str(scenario.relative_to(package_root())) if package_root() in scenario.parents
            else scenario.name, "robots": env.n_agents, "tasks": env.n_tasks,
            "reference": as_evaluated, "cpsat": cpsat, "best_makespan": best, "lower_bound": lower,
            "gap": (best - lower) / best, "methods": methods,
            "mappo": None, "ros_real_time_factor": None}


def headline(results: Sequence[Dict[str, Any]]) -> List[Dict[str, Any]]:
    by_size = {r["size"]: r for r in results}
    rows: List[Dict[str, Any]] = []
    if "4x8" in by_size:
        ref = by_size["4x8"]["reference"]
        rows.append({"figure": "4x8 (lab_4r) optimum proven in", "unit": "s",
                     "value": round(ref["time_to_optimum"], 2) if ref["time_to_optimum"] is not None else "not proven",
                     "goal": "< 1"})
    if "8x16" in by_size:
        run = by_size["8x16"]["cpsat"]["60"]
        rows.append({"figure": "8x16 (site_8r) CP-SAT gap, 60 s per model", "unit": "%",
                     "value": round(100 * run["gap"], 1), "goal": "<= 5"})
    if "16x32" in by_size:
        run = by_size["16x32"]["reference"]
        rows.append({"figure": "16x32 (site_16r) bound and schedule (evaluate's reference) in", "unit": "s",
                     "value": round(run["wall_seconds"], 1), "goal": "<= 120"})
    peak = max(m["peak_memory_mb"] for r in results for m in r["methods"].values())
    rows.append({"figure": "peak memory of any evaluate run", "unit": "MB", "value": round(peak), "goal": f"< {MEMORY_GOAL_MB:.0f}"})
    for r in results:
        rows.append({"figure": f"{r['size']} gap of the best known to the lower bound", "unit": "%",
                     "value": round(100 * r["gap"], 1), "goal": ""})
        for method in ("ga", "auction", "random"):
            rows.append({"figure": f"{r['size']} {method} / best known", "unit": "",
                         "value": round(r["methods"][method]["ratio_to_best"], 3), "goal": ""})
    return rows


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="bench_scale", description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(package_root() / "results"), help="output directory (default results/)")
    parser.add_argument("--sizes", default=None, help="comma-separated subset of 2x8,4x8,6x16,8x16,16x32 (default all)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bench_scale_") as tmp:
        work = Path(tmp)
        chosen = sizes(work)
        if args.sizes:
            wanted = args.sizes.split(",")
            unknown = sorted(set(wanted) - {label for label, _ in chosen})
            if unknown:
                print(f"bench_scale: --sizes: unknown {', '.join(unknown)}", file=sys.stderr)
                return 2
            chosen = [(label, path) for label, path in chosen if label in wanted]
        results = [bench_size(label, path, work) for label, path in chosen]
    rows = headline(results)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "bench_scale.json"
    tmp_path = path.with_name(path.name + ".tmp")
    tmp_path.write_text(json.dumps({"headline": rows, "sizes": results,
                                    "settings": {"cpsat_limits_per_model": CPSAT_LIMITS, "exact_limit": EXACT_LIMIT,
                                                 "cpsat_workers": load_baseline_settings().cpsat.workers},
                                    "cpu_count": os.cpu_count()}, indent=1))
    tmp_path.replace(path)
    width = max(len(r["figure"]) for r in rows)
    for r in rows:
        print(f"{r['figure'].ljust(width)}  {r['value']!s:>10} {r['unit']:<3} {r['goal']}")
    print(f"wrote {path}", file=sys.stderr)
    return 0
