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
- MAPPO (part `mappo`): the shipped generalist fine-tuned on the scenario (`train --init
  generalist`, a process of its own) for --mappo-seconds of training wall time: the best
  logic-consistent greedy makespan and its ratios, and the training time until it is within 5 %
  of the best known makespan; the generalist's own training time is given beside it, since a
  budget of training counts both;
- the ROS simulation (part `ros`): the reference's plan driven once through `evaluate.launch`
  (lock-step, built-in navigation, nodelets) on a master of its own: makespan, completion, logic
  consistency, collisions and the real-time factor of the episode (simulated ÷ wall seconds).
Writes <out>/bench_scale.json ({"headline": [...], ...}, the format tools/bench_table.py prints).
--parts runs some parts only; the sizes and parts not run keep their figures from the file
already there.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

from marl_mrta.apps.bench_task_ros import run_ros_evaluation
from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.common.paths import package_root
from marl_mrta.common.results import write_result
from marl_mrta.env.factory import make_env
from marl_mrta.env.settings import load_embedded_settings
from marl_mrta.model.generator import ScenarioRequest, generate_scenario

METHODS = ("random", "ga", "auction", "exact")
CPSAT_LIMITS = (10.0, 60.0)
EXACT_LIMIT = 10.0
MEMORY_GOAL_MB = 4096.0
PARTS = ("solvers", "mappo", "ros")
MAPPO_WITHIN = 1.05          # "training time to within 5 % of the best known makespan"
MAPPO_SECONDS = 300.0        # default fine-tuning wall time per size
ROS_TIMEOUT = 1800.0         # wall s for one evaluate.launch run


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


def solver_figures(label: str, scenario: Path, work: Path) -> Dict[str, Any]:
    """Part `solvers`: the reference, CP-SAT alone and every method of `evaluate`."""
    print(f"bench_scale: {label} ({scenario.name}): solvers and baselines ...", file=sys.stderr)
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
            "gap": (best - lower) / best, "methods": methods}


def generalist_training_seconds() -> Optional[float]:
    """The shipped generalist's training time (policies/generalist.json), or None."""
    summary = package_root() / "policies" / "generalist.json"
    try:
        return float(json.loads(summary.read_text())["seconds"]["total_s"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def mappo_figures(label: str, scenario: Path, best: float, lower: float, seconds: float, work: Path,
                  overrides: Sequence[str] = ()) -> Dict[str, Any]:
    """Part `mappo`: the generalist fine-tuned on the scenario for `seconds` of training wall time,
    with the preset's settings changed by `overrides` (KEY=VALUE, as train --set takes them)."""
    print(f"bench_scale: {label} ({scenario.name}): MAPPO, {seconds:g} s of fine-tuning ...", file=sys.stderr)
    out = work / f"mappo_{label}"
    argv = [sys.executable, str(package_root() / "scripts" / "train"), "--scenario", str(scenario), "--init",
            "generalist", "--set", f"max_wall_seconds={seconds:g}", "--set", "total_env_steps=100000000",
            "--out", str(out)] + [word for setting in overrides for word in ("--set", setting)]
    process = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if process.returncode != 0:
        raise RuntimeError(f"train on {scenario.name} failed: {process.stderr.strip().splitlines()[-1:]}")
    evaluations = json.loads((out / "history.json").read_text())["evaluations"]
    best_eval = min(evaluations, key=lambda e: e["consistent_makespan"])
    within = [e for e in evaluations if e["consistent_makespan"] <= MAPPO_WITHIN * best]
    makespan = best_eval["consistent_makespan"]
    return {"start": "generalist", "generalist_training_s": generalist_training_seconds(),
            "fine_tuning_s": evaluations[-1]["wall_time"], "updates": evaluations[-1]["update"],
            "env_steps": evaluations[-1]["env_steps"], "first_greedy_makespan": evaluations[0]["consistent_makespan"],
            "greedy_makespan": makespan, "greedy_at_s": best_eval["wall_time"],
            "ratio_to_best": makespan / best, "ratio_to_lower_bound": makespan / lower if lower > 0 else None,
            "time_to_within_5pct_s": within[0]["wall_time"] if within else None,
            "settings": list(overrides),
            "command": " ".join([f"train --scenario {scenario.name} --init generalist --set max_wall_seconds={seconds:g}"]
                                + [f"--set {setting}" for setting in overrides])}


def ros_figures(label: str, scenario: Path, work: Path) -> Dict[str, Any]:
    """Part `ros`: the reference's plan once through the ROS simulation in lock-step."""
    print(f"bench_scale: {label} ({scenario.name}): the exact plan in the ROS simulation ...", file=sys.stderr)
    out = work / f"ros_{label}.json"
    wall = run_ros_evaluation(scenario, 1, out, 0, ROS_TIMEOUT, methods=("exact",))
    result = json.loads(out.read_text())["results"][0]
    summary = result["summary"]
    simulated = sum(e["makespan"] for e in result["episodes"])
    return {"makespan": summary["makespan_mean"], "complete_pct": summary["complete_pct"],
            "logic_consistent_pct": summary["logic_consistent_pct"],
            "collisions_per_episode": summary["collisions_per_episode"], "episode_wall_s": result["seconds"],
            "real_time_factor": simulated / result["seconds"], "launch_wall_s": wall}


def bench_size(label: str, scenario: Path, work: Path, parts: Sequence[str], mappo_seconds: float,
               previous: Optional[Dict[str, Any]], logs: Path, mappo_overrides: Sequence[str] = ()) -> Dict[str, Any]:
    """One size's figures: the parts asked for, the others as `previous` had them; the log of a
    failed ROS run is kept in `logs`."""
    result: Dict[str, Any] = dict(previous or {})
    result.setdefault("mappo", None)
    result.setdefault("ros", None)
    if "solvers" in parts or "best_makespan" not in result:
        result.update(solver_figures(label, scenario, work))
    # A part that fails is recorded as failed, with its one line; the other figures stand.
    if "mappo" in parts:
        try:
            result["mappo"] = mappo_figures(label, scenario, result["best_makespan"], result["lower_bound"],
                                            mappo_seconds, work, mappo_overrides)
        except RuntimeError as error:
            result["mappo"] = {"error": str(error)}
    if "ros" in parts:
        try:
            ros = ros_figures(label, scenario, work)
            ros["ratio_to_best_plan"] = ros["makespan"] / result["best_makespan"]
            result["ros"] = ros
        except RuntimeError as error:
            # The launch's log outlives the temporary directory beside the result file.
            log = work / f"ros_{label}.log"
            kept = logs / f"bench_scale_ros_{label}.log"
            if log.is_file():
                logs.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(log, kept)
            result["ros"] = {"error": str(error).replace(str(log), str(kept))}
    result.pop("ros_real_time_factor", None)   # the key of files before the `ros` part
    return result


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
    mappo_goals = {"8x16": "<= 1.05 in 1 h", "16x32": "<= 1.10 in 1 h"}
    for r in results:
        rows.append({"figure": f"{r['size']} gap of the best known to the lower bound", "unit": "%",
                     "value": round(100 * r["gap"], 1), "goal": ""})
        for method in ("ga", "auction", "random"):
            rows.append({"figure": f"{r['size']} {method} / best known", "unit": "",
                         "value": round(r["methods"][method]["ratio_to_best"], 3), "goal": ""})
        for part in ("mappo", "ros"):
            if r.get(part) and "error" in r[part]:
                rows.append({"figure": f"{r['size']} {part}", "unit": "", "value": "failed", "goal": r[part]["error"]})
        mappo = r.get("mappo")
        if mappo and "error" not in mappo:
            before = mappo["generalist_training_s"]
            changed = "".join(f", {setting}" for setting in mappo.get("settings", []))
            rows.append({"figure": f"{r['size']} MAPPO (generalist + {mappo['fine_tuning_s']:.0f} s of fine-tuning"
                                   f"{f', {before:.0f} s before' if before else ''}{changed}) / lower bound", "unit": "",
                         "value": round(mappo["ratio_to_lower_bound"], 3), "goal": mappo_goals.get(r["size"], "")})
            to_5 = mappo["time_to_within_5pct_s"]
            rows.append({"figure": f"{r['size']} MAPPO fine-tuning to within 5 % of the best known",
                         "unit": "s" if to_5 is not None else "",
                         "value": round(to_5, 1) if to_5 is not None else "not reached", "goal": ""})
        ros = r.get("ros")
        if ros and "error" not in ros:
            rows.append({"figure": f"{r['size']} ROS lock-step, exact plan: real-time factor", "unit": "x",
                         "value": round(ros["real_time_factor"], 1), "goal": ""})
            rows.append({"figure": f"{r['size']} ROS lock-step, exact plan: makespan / planned (logic-consistent %)",
                         "unit": "", "value": f"{ros['ratio_to_best_plan']:.3f} ({ros['logic_consistent_pct']:.0f} %)",
                         "goal": ""})
    return rows


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="bench_scale", description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(package_root() / "results"), help="output directory (default results/)")
    parser.add_argument("--sizes", default=None, help="comma-separated subset of 2x8,4x8,6x16,8x16,16x32 (default all)")
    parser.add_argument("--parts", default=",".join(PARTS),
                        help=f"comma-separated subset of {','.join(PARTS)} (default all; ros needs a sourced ROS "
                             "workspace); the others keep their figures from the existing file")
    parser.add_argument("--mappo-seconds", type=float, default=MAPPO_SECONDS,
                        help=f"fine-tuning wall time per size for part mappo (default {MAPPO_SECONDS:g})")
    parser.add_argument("--mappo-set", action="append", default=[], metavar="KEY=VALUE",
                        help="a fine-tuning setting for part mappo, passed to train --set (repeatable), e.g. "
                             "teacher=reference")
    args = parser.parse_args(argv)
    parts = args.parts.split(",")
    unknown_parts = sorted(set(parts) - set(PARTS))
    if unknown_parts or args.mappo_seconds <= 0:
        problem = f"--parts: unknown {', '.join(unknown_parts)}" if unknown_parts else "--mappo-seconds: must be > 0"
        print(f"bench_scale: {problem}", file=sys.stderr)
        return 2
    out = Path(args.out)
    path = out / "bench_scale.json"
    previous: Dict[str, Dict[str, Any]] = {}
    mappo_run = {"mappo_seconds": args.mappo_seconds, "mappo_settings": args.mappo_set}
    if path.is_file():
        try:
            document = json.loads(path.read_text())
            previous = {r["size"]: r for r in document["sizes"]}
            if "mappo" not in parts:   # the kept MAPPO figures keep the settings they were run with
                kept = document.get("settings", {})
                mappo_run = {key: kept.get(key, value) for key, value in mappo_run.items()}
        except (ValueError, KeyError, TypeError):
            print(f"bench_scale: {path}: not a bench_scale result; every part is run", file=sys.stderr)
    with tempfile.TemporaryDirectory(prefix="bench_scale_") as tmp:
        work = Path(tmp)
        chosen = sizes(work)
        if args.sizes:
            wanted = args.sizes.split(",")
            unknown = sorted(set(wanted) - {label for label, _ in chosen})
            if unknown:
                print(f"bench_scale: --sizes: unknown {', '.join(unknown)}", file=sys.stderr)
                return 2
        else:
            wanted = [label for label, _ in chosen]
        results = [bench_size(label, scenario, work, parts, args.mappo_seconds, previous.get(label), out,
                              args.mappo_set)
                   if label in wanted else previous[label]
                   for label, scenario in chosen if label in wanted or label in previous]
    rows = headline(results)
    kept_earlier = bool(previous) and (set(parts) != set(PARTS) or len(wanted) < len(chosen) or
                                       any(label not in wanted for label in previous))
    write_result(path, {"headline": rows, "sizes": results,
                        "settings": {"cpsat_limits_per_model": CPSAT_LIMITS, "exact_limit": EXACT_LIMIT,
                                     "cpsat_workers": load_baseline_settings().cpsat.workers, **mappo_run},
                        "cpu_count": os.cpu_count()}, keeps_earlier=kept_earlier)
    width = max(len(r["figure"]) for r in rows)
    for r in rows:
        print(f"{r['figure'].ljust(width)}  {r['value']!s:>10} {r['unit']:<3} {r['goal']}")
    print(f"wrote {path}", file=sys.stderr)
    return 0
