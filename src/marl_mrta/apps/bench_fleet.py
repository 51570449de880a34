"""Benchmark: a live fleet (tasks released over time, robots lost) against a planner told everything.

    rosrun marl_mrta bench_fleet [--out results] [--scenarios site_8r,site_16r] [--seeds 5] [--seed 31]
        [--known-share 0.25] [--release-span 0.5] [--fault-window 0.2 0.6] [--reference-seconds 30]

Per scenario and seed, three live variants (model/live_variants.py), in event mode:
- `releases`: `--known-share` of the tasks known at the start, the others released in an order
  that keeps precedence, at the arrivals of a Poisson process whose expected last release is
  `--release-span` x the scenario's static event reference makespan;
- `releases, 1 lost` and `releases, 2 lost`: the same releases, and one or two robots (drawn at
  random) leaving at times drawn from `--fault-window` x that makespan.
Per variant:
- the live fleet: an episode on the embedded executor (ideal profile, nominal legs) with the
  replanning allocator (config/task_baselines.yaml `replan`), which learns of each task at its
  release and of each robot's departure when it happens: makespan, mean completion time (the mean
  of the tasks' finish times), plans made and their wall time; nothing lost (every released task
  finished, or refused: none is, here);
- the plan of the same planner told everything at the start (baselines/replan.py,
  full_information_instance: releases, and when each robot leaves), with CP-SAT's asynchronous
  model for `--reference-seconds` of deterministic time (the least makespan, then the least sum
  of finish times within it), starting from the live fleet's own routes: its makespan, mean
  completion time and lower bound.
Ratios are live / told everything (goal: <= 1.15 for both figures). The variants are written to
<out>/bench_fleet/ as scenario files. Writes <out>/bench_fleet.json (headline first,
tools/gen_docs.py).
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence

from marl_mrta.baselines.plan import decode_routes
from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.baselines.replan import full_information_instance, repair
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import package_root
from marl_mrta.common.results import write_result
from marl_mrta.env.factory import make_env
from marl_mrta.env.settings import load_task_settings
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.policies import ReplanPolicy
from marl_mrta.model.live_variants import live_variant, write_variant
from marl_mrta.model.scenario import Scenario, ScenarioError, load_scenario

GOAL = 1.15
KINDS = (("releases", 0), ("releases, 1 lost", 1), ("releases, 2 lost", 2))


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bench_fleet", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=package_root() / "results", help="directory of bench_fleet.json")
    parser.add_argument("--scenarios", default="site_8r,site_16r", help="shipped scenarios (default site_8r,site_16r)")
    parser.add_argument("--seeds", type=int, default=5, help="variants of each kind per scenario (default 5)")
    parser.add_argument("--seed", type=int, default=31, help="first seed of the variants (default 31)")
    parser.add_argument("--known-share", type=float, default=0.25,
                        help="share of the tasks known at the start (default 0.25)")
    parser.add_argument("--release-span", type=float, default=0.5,
                        help="expected last release, x the static event reference makespan (default 0.5)")
    parser.add_argument("--fault-window", type=float, nargs=2, default=(0.2, 0.6), metavar=("FROM", "TO"),
                        help="robots leave within this window, x that makespan (default 0.2 0.6)")
    parser.add_argument("--reference-seconds", type=float, default=30.0,
                        help="CP-SAT deterministic s of the plan told everything (default 30)")
    return parser


def mean_completion(finishes: Sequence[Optional[float]]) -> float:
    """The mean of the tasks' finish times (inf when one is missing)."""
    return statistics.mean(f if f is not None else math.inf for f in finishes) if finishes else 0.0


def live_episode(variant: Scenario, settings) -> Dict[str, Any]:
    env = make_env(variant, "embedded", profile="ideal", decision_mode="event", seed=0)
    policy = ReplanPolicy(env, settings.replan)
    started = time.perf_counter()
    record = run_episode(env, policy, seed=0)
    wall = time.perf_counter() - started
    released = [j for j, at in enumerate(record.released_at) if at is not None]
    lost = [variant.tasks[j].id for j in released if record.finish_time[j] is None]
    return {"makespan": record.makespan, "mean_completion": mean_completion(record.finish_time),
            "complete": record.complete, "logic_consistent": record.logic_consistent, "lost_tasks": lost,
            "plans": policy.plans, "wall_s": wall, "events": len(record.fleet_events),
            "routes": record.robot_task_lists()}


def told_everything(variant: Scenario, settings, seconds: float, live_routes) -> Dict[str, Any]:
    """The planner told everything, from the live fleet's own routes as its first plan (they are a
    plan of the same instance: what the live fleet did is one thing a planner told everything could
    have planned), so it is never longer than the live fleet."""
    env = make_env(variant, "embedded", profile="ideal", decision_mode="event", seed=0)
    instance = full_information_instance(variant, env.table, env.settings.goal_timeout.planning_limit,
                                         env.settings.min_step)
    started = time.perf_counter()
    plan = repair(instance, live_routes, dataclasses.replace(settings.replan, method="cpsat", time_limit=seconds,
                                                             ga_evaluations=settings.ga.max_evaluations))
    run = decode_routes(instance, plan.robot_tasks)
    return {"makespan": plan.makespan, "mean_completion": mean_completion(run.finish),
            "lower_bound": plan.details.get("lower_bound", 0.0), "source": plan.details.get("source", ""),
            "wall_s": time.perf_counter() - started}


def bench(args: argparse.Namespace, log: Callable[[str], None] = print) -> Dict[str, Any]:
    settings = load_baseline_settings()
    task = load_task_settings()
    names = [n.strip() for n in args.scenarios.split(",") if n.strip()]
    rows: List[Dict[str, Any]] = []
    for name in names:
        scenario = load_scenario(package_root() / "scenarios" / f"{name}.xml")
        own = task.for_scenario(scenario)
        static = solve_reference(scheduling_instance(scenario, own.min_step, own.goal_timeout, decision_mode="event"),
                                 settings.with_cpsat(time_limit=args.reference_seconds)).best_makespan
        log(f"{name}: static event reference {static:.2f} s")
        for k in range(args.seeds):
            seed = args.seed + k
            for kind, faults in KINDS:
                variant = live_variant(scenario, seed, args.known_share, args.release_span * static, faults,
                                       (args.fault_window[0] * static, args.fault_window[1] * static),
                                       name_suffix=f"_live{seed}_{faults}lost")
                write_variant(variant, args.out / "bench_fleet" / f"{variant.name}.xml")
                live = live_episode(variant, settings)
                full = told_everything(variant, settings, args.reference_seconds, live.pop("routes"))
                row = {"scenario": name, "seed": seed, "kind": kind, "variant": variant.name, "live": live,
                       "told_everything": full, "makespan_ratio": live["makespan"] / full["makespan"],
                       "completion_ratio": live["mean_completion"] / full["mean_completion"]}
                rows.append(row)
                log(f"{variant.name} ({kind}): live {live['makespan']:.2f} s, told everything {full['makespan']:.2f} s "
                    f"({row['makespan_ratio']:.3f}); mean completion {row['completion_ratio']:.3f}; "
                    f"{live['plans']} plans in {live['wall_s']:.1f} s; lost {len(live['lost_tasks'])}")
    return report(rows, args, settings)


def report(rows: List[Dict[str, Any]], args: argparse.Namespace, settings) -> Dict[str, Any]:
    headline: List[Dict[str, Any]] = []
    figures: Dict[str, Any] = {}
    for name in sorted({r["scenario"] for r in rows}, key=[r["scenario"] for r in rows].index):
        for kind, _ in KINDS:
            mine = [r for r in rows if r["scenario"] == name and r["kind"] == kind]
            if not mine:
                continue
            key = f"{name}: {kind}"
            figures[key] = {"makespan_ratio_mean": statistics.mean(r["makespan_ratio"] for r in mine),
                            "makespan_ratio_max": max(r["makespan_ratio"] for r in mine),
                            "completion_ratio_mean": statistics.mean(r["completion_ratio"] for r in mine),
                            "completion_ratio_max": max(r["completion_ratio"] for r in mine),
                            "variants": len(mine)}
            headline.append({"figure": f"{key}: live makespan / told everything, mean of {len(mine)} (max beside it in the file)",
                             "unit": "", "value": round(figures[key]["makespan_ratio_mean"], 4), "goal": f"<= {GOAL}"})
            headline.append({"figure": f"{key}: live mean completion time / told everything, mean of {len(mine)}",
                             "unit": "", "value": round(figures[key]["completion_ratio_mean"], 4), "goal": f"<= {GOAL}"})
    lost = sum(len(r["live"]["lost_tasks"]) for r in rows)
    out_of_order = sum(1 for r in rows if not r["live"]["logic_consistent"])
    headline.append({"figure": f"tasks lost over {len(rows)} live episodes (released, neither finished nor refused)",
                     "unit": "", "value": lost, "goal": "0"})
    headline.append({"figure": "live episodes not complete in order", "unit": "", "value": out_of_order, "goal": "0"})
    replan = settings.replan
    return {"headline": headline, "figures": figures, "rows": rows,
            "settings": {"scenarios": args.scenarios, "seeds": args.seeds, "seed": args.seed,
                         "known_share": args.known_share, "release_span": args.release_span,
                         "fault_window": list(args.fault_window), "reference_seconds": args.reference_seconds,
                         "replan": {"method": replan.method, "time_limit": replan.time_limit,
                                    "ga_evaluations": replan.ga_evaluations, "delay": replan.delay}}}


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        result = bench(args, log=lambda line: print(line, file=sys.stderr, flush=True))
    except (ScenarioError, ConfigError, ValueError) as error:
        print(f"bench_fleet: {error}", file=sys.stderr)
        return 2
    write_result(args.out / "bench_fleet.json", result)
    for row in result["headline"]:
        print(f"{row['figure']}: {row['value']} {row['unit']} (goal {row['goal'] or '-'})")
    return 0
