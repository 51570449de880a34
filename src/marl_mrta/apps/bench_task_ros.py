"""bench_task_ros: the paper's Table 9 in the ROS simulation, and how well the embedded executor agrees.

For each scenario, `roslaunch marl_mrta evaluate.launch` (simulator in lock-step as fast as
possible, built-in navigation, task manager, the evaluation command with the ros executor) runs
random, GA, auction and exact for N episodes and writes DIR/bench_task_ros/evaluate_ros_<scenario>.json. Then:
- agreement: the exact schedule's makespan in the embedded executor (nominal travel times) vs
  its mean in the ROS simulation on lab_2r (goal: within 15 %);
- Table 9: mean makespan per method, ratios to the exact schedule's ROS mean, random ÷ GA
  beside the paper's 2.46 (2 robots) and 2.59 (4 robots);
- whole-episode real-time factor: simulated episode time ÷ wall time of the evaluation.
Writes DIR/bench_task_ros.json (with the benchmark convention's "headline").
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

from marl_mrta.baselines.reference import scenario_reference
from marl_mrta.common.paths import package_root
from marl_mrta.common.results import write_result
from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.evaluation.policies import PlanPolicy
from marl_mrta.ros.process_group import free_port

METHODS = ("random", "ga", "auction", "exact")
PAPER_RANDOM_OVER_GA = {2: 2.46, 4: 2.59}
AGREEMENT_GOAL = 0.15


def run_ros_evaluation(scenario: Path, episodes: int, out: Path, seed: int, timeout: float,
                       methods: Sequence[str] = METHODS, extra: Sequence[str] = ()) -> float:
    """evaluate.launch (with `extra` arguments) on its own master; returns its wall time. Raises
    RuntimeError on failure."""
    out = Path(out).resolve()   # the launched nodes run in ROS_HOME, not here
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{port}")
    command = ["roslaunch", "-p", str(port), "marl_mrta", "evaluate.launch", f"scenario:={scenario}",
               f"method:={','.join(methods)}", f"episodes:={episodes}", f"seed:={seed}", f"out:={out}", *extra]
    print(f"{Path(sys.argv[0]).name}: {' '.join(command)}", file=sys.stderr, flush=True)
    started = time.monotonic()
    log = out.with_suffix(".log")
    log.parent.mkdir(parents=True, exist_ok=True)
    with open(log, "w") as stream:
        try:
            result = subprocess.run(command, env=env, stdout=stream, stderr=subprocess.STDOUT, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"{scenario.name}: evaluate.launch did not finish within {timeout:.0f} s (log {log})") from None
    if not out.is_file() or out.stat().st_mtime < time.time() - (time.monotonic() - started) - 1.0:
        raise RuntimeError(f"{scenario.name}: evaluate.launch wrote no {out} (exit {result.returncode}, log {log})")
    return time.monotonic() - started


def embedded_exact_makespan(scenario: Path) -> float:
    """The exact schedule replayed through the embedded executor (nominal travel times)."""
    env = make_env(scenario, seed=0)
    plan, _ = scenario_reference(env.scenario, env.settings.min_step)
    return run_episodes(env, PlanPolicy(plan, env.n_agents, env.n_tasks), 1, seed=0)[0].makespan


def summarise(document: Dict[str, Any], scenario: Path) -> Dict[str, Any]:
    """Table 9 figures of one evaluate_ros JSON."""
    by_method = {r["summary"]["method"]: r for r in document["results"]}
    exact_ros = by_method["exact"]["summary"]["makespan_mean"]
    rows = {}
    sim_time = wall_time = 0.0
    for method, result in by_method.items():
        s = result["summary"]
        episode_time = sum(e["makespan"] for e in result["episodes"])
        sim_time += episode_time
        wall_time += result["seconds"]
        rows[method] = {
            "episodes": s["episodes"], "makespan_mean": s["makespan_mean"], "makespan_sd": s["makespan_sd"],
            "complete_pct": s["complete_pct"], "logic_consistent_pct": s["logic_consistent_pct"],
            "decision_steps_mean": s["decision_steps_mean"], "collisions_per_episode": s["collisions_per_episode"],
            "ratio_to_exact_ros": s["makespan_mean"] / exact_ros,
            "ratio_to_exact_nominal": s["ratio_to_exact"], "allocation": s["allocation"],
            "wall_seconds": result["seconds"], "real_time_factor": episode_time / result["seconds"],
        }
    exact_plan = document["exact"]
    return {
        "scenario": document["scenario_name"], "robots": by_method["exact"]["summary"]["n_robots"],
        "episodes": document["episodes"], "exact_nominal_makespan": exact_plan["makespan"],
        "exact_embedded_makespan": embedded_exact_makespan(scenario),
        "exact_ros_mean": exact_ros, "methods": rows,
        "random_over_ga": rows["random"]["makespan_mean"] / rows["ga"]["makespan_mean"],
        "real_time_factor": sim_time / wall_time, "episode_seconds": sim_time, "wall_seconds": wall_time,
    }


def format_table(summaries: Sequence[Dict[str, Any]]) -> str:
    header = ("scenario", "method", "episodes", "makespan (s)", "ratio to exact (ROS)", "complete", "logic-consistent",
              "steps/ep", "collisions/ep", "rtf")
    rows = []
    for s in summaries:
        for method in METHODS:
            r = s["methods"][method]
            rows.append((s["scenario"], method, str(r["episodes"]), f"{r['makespan_mean']:.2f} ± {r['makespan_sd']:.2f}",
                         f"{r['ratio_to_exact_ros']:.3f}", f"{r['complete_pct']:.0f} %",
                         f"{r['logic_consistent_pct']:.0f} %", f"{r['decision_steps_mean']:.2f}",
                         f"{r['collisions_per_episode']:.2f}", f"{r['real_time_factor']:.1f}"))
    widths = [max(len(row[i]) for row in rows + [header]) for i in range(len(header))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in [header] + rows)


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="bench_task_ros", description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(package_root() / "results"), help="output directory (default results/)")
    parser.add_argument("--scenarios", default="lab_2r,lab_3r,lab_4r",
                        help="scenarios of scenarios/, comma-separated (default lab_2r,lab_3r,lab_4r)")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per method and scenario (default 20)")
    parser.add_argument("--seed", type=int, default=0, help="seed of episodes and planners (default 0)")
    parser.add_argument("--timeout", type=float, default=4 * 3600.0, help="wall s allowed per scenario (default 4 h)")
    parser.add_argument("--reuse", action="store_true",
                        help="use DIR/bench_task_ros/evaluate_ros_<scenario>.json where it exists with as many episodes")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summaries = []
    for name in [n.strip() for n in args.scenarios.split(",") if n.strip()]:
        scenario = package_root() / "scenarios" / f"{name}.xml"
        path = out / "bench_task_ros" / f"evaluate_ros_{name}.json"   # with its Gantt charts
        reuse = args.reuse and path.is_file() and json.loads(path.read_text()).get("episodes") == args.episodes
        if not reuse:
            try:
                run_ros_evaluation(scenario, args.episodes, path, args.seed, args.timeout)
            except RuntimeError as error:
                print(f"bench_task_ros: {error}", file=sys.stderr)
                return 1
        summaries.append(summarise(json.loads(path.read_text()), scenario))

    headline: List[Dict[str, Any]] = []
    by_name = {s["scenario"]: s for s in summaries}
    if "lab_2r" in by_name:
        s = by_name["lab_2r"]
        gap = abs(s["exact_embedded_makespan"] - s["exact_ros_mean"]) / s["exact_ros_mean"]
        headline += [
            {"figure": "lab_2r exact schedule: embedded makespan", "value": round(s["exact_embedded_makespan"], 2),
             "unit": "s", "goal": ""},
            {"figure": f"lab_2r exact schedule: ROS simulation mean ({s['methods']['exact']['episodes']} episodes)",
             "value": round(s["exact_ros_mean"], 2), "unit": "s", "goal": ""},
            {"figure": "lab_2r exact schedule: |embedded - ROS| / ROS", "value": round(100.0 * gap, 1), "unit": "%",
             "goal": f"<= {100 * AGREEMENT_GOAL:.0f}"},
        ]
    for s in summaries:
        for method in ("random", "ga", "auction"):
            headline.append({"figure": f"{s['scenario']} ROS {method} / exact", "unit": "",
                             "value": round(s["methods"][method]["ratio_to_exact_ros"], 3), "goal": ""})
        paper = PAPER_RANDOM_OVER_GA.get(s["robots"])
        headline.append({"figure": f"{s['scenario']} ROS random / GA", "unit": "", "value": round(s["random_over_ga"], 3),
                         "goal": f"paper: {paper}" if paper else ""})
    sim_time = sum(s["episode_seconds"] for s in summaries)
    wall_time = sum(s["wall_seconds"] for s in summaries)
    if summaries:
        headline.append({"figure": "ROS evaluation whole-episode real-time factor (episode time / wall time)",
                         "unit": "x", "value": round(sim_time / wall_time, 2), "goal": ""})
    write_result(out / "bench_task_ros.json", {"headline": headline, "scenarios": summaries, "methods": list(METHODS),
                                               "seed": args.seed, "cpu_count": os.cpu_count()})
    print(format_table(summaries))
    width = max((len(h["figure"]) for h in headline), default=0)
    print("== headline")
    for h in headline:
        print(f"{h['figure'].ljust(width)}  {h['value']!s:>10} {h['unit']:<3} {h['goal']}")
    print(f"wrote {out / 'bench_task_ros.json'}", file=sys.stderr)
    return 0
