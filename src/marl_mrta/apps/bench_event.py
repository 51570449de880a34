"""Benchmark: the paper's synchronous decision steps against event mode, side by side.

    rosrun marl_mrta bench_event [--out results] [--generated 20] [--robots 6 16] [--tasks 12 32]
        [--reference-seconds 20] [--finetune-seconds 60] [--seed 21] [--ros lab_2r,lab_4r,site_8r,site_16r]

Scenarios: the three labs, site_8r, site_16r, and `--generated` scenarios drawn by the generator
(teams and task counts in the given ranges, from `--seed`, which no training uses). Per scenario
and decision mode (embedded executor, ideal):
- the reference: the best known plan, its proven lower bound and gap (synchronous: A* or the CP-SAT
  step models; event: the asynchronous CP-SAT model), within `--reference-seconds` of CP-SAT
  deterministic time per model, and the wall time it took;
- the reference plan's episode: makespan and idle share (the time robots wait between their tasks,
  summed over robots, over the time from the start to each robot's last finish);
- the GA's plan;
- the shipped generalist zero-shot (its greedy episode), and fine-tuned on the scenario for
  `--finetune-seconds` of wall time (train's default preset, its teacher the mode's reference);
- on the `--ros` scenarios, the reference plan run once in the ROS simulation (evaluate.launch,
  lock-step, built-in navigation) in each mode: its makespan against the embedded plan's, and its
  legs against their nominal times (the longest ratio and excess: what a goal timeout must allow).
Ratios are to the mode's own best known makespan. The event/synchronous ratio of the best known
makespans says what the step barrier costs. Gantt charts of both modes' reference episodes go to
<out>/bench_event/. Writes <out>/bench_event.json (headline first, tools/gen_docs.py).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np
import torch

from marl_mrta.apps.bench_generalise import ratio, summary_of, trained
from marl_mrta.apps.bench_task_ros import run_ros_evaluation
from marl_mrta.apps.train_generalist import generated_scenarios
from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import package_root
from marl_mrta.common.results import write_result
from marl_mrta.env.factory import make_env
from marl_mrta.env.settings import DECISION_MODES, load_task_settings
from marl_mrta.evaluation.gantt import plot_gantt
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.policies import LearnedPolicy, plan_policy
from marl_mrta.mappo.policy import load_policy, read_actor_file
from marl_mrta.model.generator import GeneratorError
from marl_mrta.model.scenario import Scenario, ScenarioError, load_scenario

NAMED = ("lab_2r", "lab_3r", "lab_4r", "site_8r", "site_16r")
#: The issue's goals.
GOALS = {"site_16r_event_over_sync": 0.85, "gap": 0.05, "learned": 1.03, "idle_share_16x32": 0.10}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bench_event", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=package_root() / "results", help="directory of bench_event.json")
    parser.add_argument("--generated", type=int, default=20, help="generated scenarios besides the named ones (default 20)")
    parser.add_argument("--robots", type=int, nargs=2, default=(6, 16), metavar=("MIN", "MAX"), help="(default 6 16)")
    parser.add_argument("--tasks", type=int, nargs=2, default=(12, 32), metavar=("MIN", "MAX"), help="(default 12 32)")
    parser.add_argument("--seed", type=int, default=21, help="seed of the generated scenarios (default 21)")
    parser.add_argument("--reference-seconds", type=float, default=20.0,
                        help="CP-SAT deterministic s per model of each reference (default 20)")
    parser.add_argument("--finetune-seconds", type=float, default=60.0,
                        help="wall s of fine-tuning the generalist per scenario and mode (default 60; 0: none)")
    parser.add_argument("--finetune-modes", default="event",
                        help="decision modes in which the generalist is fine-tuned (default event)")
    parser.add_argument("--ros", default="lab_2r,lab_4r,site_8r,site_16r",
                        help="named scenarios whose reference plan also runs in the ROS simulation in both modes "
                             "(evaluate.launch: lock-step, built-in navigation; one episode each); empty: none")
    return parser


def ros_episode(scenario: Scenario, mode: str, work: Path) -> Dict[str, Any]:
    """The mode's reference plan in the ROS simulation: its makespan against the embedded plan's,
    complete and in order, and each leg's time against its nominal one."""
    out = work / f"ros_{scenario.name}_{mode}.json"
    try:
        run_ros_evaluation(scenario.source, 1, out, 0, 3600.0, ("exact",), (f"decision_mode:={mode}",))
    except RuntimeError as error:
        return {"error": str(error)}
    document = json.loads(out.read_text())
    result = document["results"][0]
    episode = result["representative_episode"]
    planned = document["exact"]["makespan"]
    task = load_task_settings().for_scenario(scenario)
    instance = scheduling_instance(scenario, task.min_step, task.goal_timeout, decision_mode=mode)
    legs = leg_times(episode, instance)
    return {"makespan": episode["makespan"], "planned": planned, "ratio": episode["makespan"] / planned,
            "complete": episode["complete"], "logic_consistent": episode["logic_consistent"],
            "leg_ratio_max": max((ros / nominal for ros, nominal in legs if nominal > 0), default=math.nan),
            "leg_excess_max_s": max((ros - nominal for ros, nominal in legs), default=math.nan),
            "leg_excess_mean_s": float(np.mean([ros - nominal for ros, nominal in legs])) if legs else math.nan}


def leg_times(episode: Dict[str, Any], instance) -> List[Tuple[float, float]]:
    """(driven, nominal) s of every leg that arrived, from where its robot stood (its start pose,
    then the goal of the task it last reached)."""
    at = list(range(instance.n_robots))
    legs = []
    for entry in sorted(episode["entries"], key=lambda e: (e["robot"], e["start"])):
        if entry["reach"] is None:
            continue
        task = entry["task"]
        legs.append((entry["reach"] - entry["start"], instance.travel_rows[at[entry["robot"]]][instance.node(task)]))
        at[entry["robot"]] = instance.node(task)
    return legs


def idle_share(record, scenario: Scenario) -> float:
    return record.idle_share([t.service_time for t in scenario.tasks])


def one_mode(scenario: Scenario, mode: str, settings, task, policy, mask: str, finetune_s: float, work: Path,
             gantt_dir: Optional[Path]) -> Dict[str, Any]:
    own = task.for_scenario(scenario)   # the scenario's own goal timeout over config/task.yaml's
    instance = scheduling_instance(scenario, own.min_step, own.goal_timeout, decision_mode=mode)
    ga = solve_ga(instance, settings.ga, seed=0)
    started = time.perf_counter()
    reference = solve_reference(instance, settings, candidates=[ga])
    reference_s = time.perf_counter() - started
    best = reference.best_makespan
    env = make_env(scenario, "embedded", profile="ideal", mask=mask, decision_mode=mode, seed=0)
    record = run_episode(env, plan_policy(reference.plan, env.n_agents, env.n_tasks, mode), seed=0)
    if gantt_dir is not None:
        plot_gantt(record, [t.category for t in scenario.tasks], gantt_dir / f"{scenario.name}_{mode}_gantt.png",
                   title=f"{scenario.name}, {mode} mode: the reference plan, {record.makespan:.2f} s")
    shot = run_episode(env, LearnedPolicy(policy.for_scenario(scenario), env.n_agents), seed=0)
    row: Dict[str, Any] = {
        "best": best, "bound": reference.lower_bound, "gap": reference.gap, "proven_optimal": reference.proven_optimal,
        "reference_s": reference_s, "reference_source": reference.best_source,
        "plan_episode": record.makespan, "idle_share": idle_share(record, scenario),
        "robot_idle_share": [robot_share(record, scenario, i) for i in range(scenario.n_robots)],
        "ga": ratio(ga.usable_makespan, best),
        "zero_shot": ratio(shot.makespan if shot.complete and shot.logic_consistent else math.inf, best),
        "zero_shot_idle_share": idle_share(shot, scenario)}
    if finetune_s > 0:
        tuned = trained(scenario, "finetune", finetune_s, 0, "generalist", work, decision_mode=mode)
        row["finetuned"], row["finetune_wall_s"] = ratio(tuned["makespan"], best), tuned["wall_s"]
    return row


def robot_share(record, scenario: Scenario, robot: int) -> float:
    """One robot's idle share (its waits over the time to its last finish; 0 if it finished nothing)."""
    alone = type(record)(record.scenario, record.robot_ids, record.task_ids,
                         entries=[e for e in record.entries if e.robot == robot])
    return idle_share(alone, scenario)


def bench(args: argparse.Namespace, log: Callable[[str], None] = print) -> Dict[str, Any]:
    torch.set_num_threads(1)
    path, data = read_actor_file("generalist")
    policy = load_policy(path)
    mask = str(data["settings"].get("action_mask", "finished"))
    settings = load_baseline_settings().with_cpsat(time_limit=args.reference_seconds)
    task = load_task_settings()
    finetune_modes = [m.strip() for m in args.finetune_modes.split(",") if m.strip()]
    gantt_dir = args.out / "bench_event"
    ros_names = [n.strip() for n in args.ros.split(",") if n.strip()]
    rows: List[Dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="bench_event_") as tmp:
        work = Path(tmp)
        named = [load_scenario(package_root() / "scenarios" / f"{name}.xml") for name in NAMED]
        generated = generated_scenarios(args.generated, args.seed, work / "scenarios", "gen",
                                        tuple(args.robots), tuple(args.tasks)) if args.generated else []
        for k, scenario in enumerate(named + generated):
            row: Dict[str, Any] = {"scenario": scenario.name, "named": k < len(named),
                                   "robots": scenario.n_robots, "tasks": scenario.n_tasks}
            for mode in DECISION_MODES:
                row[mode] = one_mode(scenario, mode, settings, task, policy, mask,
                                     args.finetune_seconds if mode in finetune_modes else 0.0, work / f"{k}_{mode}",
                                     gantt_dir if k < len(named) else None)
            row["event_over_sync"] = row["event"]["best"] / row["synchronous"]["best"]
            if scenario.name in ros_names:
                row["ros"] = {mode: ros_episode(scenario, mode, work) for mode in DECISION_MODES}
            rows.append(row)
            sync, event = row["synchronous"], row["event"]
            log(f"{k + 1}/{len(named) + len(generated)} {scenario.name} {scenario.n_robots}x{scenario.n_tasks}: "
                f"best {sync['best']:.2f} s synchronous, {event['best']:.2f} s event ({row['event_over_sync']:.3f}; "
                f"gap {100 * event['gap']:.1f} % in {event['reference_s']:.0f} s); idle share "
                f"{100 * sync['idle_share']:.1f} % / {100 * event['idle_share']:.1f} %; event zero-shot "
                f"{event['zero_shot']:.3f}" + (f", fine-tuned {event['finetuned']:.3f}" if "finetuned" in event else ""))
    return report(rows, args)


def report(rows: List[Dict[str, Any]], args: argparse.Namespace) -> Dict[str, Any]:
    by_name = {r["scenario"]: r for r in rows}
    gen = [r for r in rows if not r["named"]]

    def mean(values: Sequence[float]) -> float:
        finite = [v for v in values if math.isfinite(v)]
        return float(np.mean(finite)) if finite else math.inf

    figures = {
        "generated_event_over_sync_mean": mean([r["event_over_sync"] for r in gen]),
        "generated_event_over_sync_min": min((r["event_over_sync"] for r in gen), default=math.inf),
        "generated_idle_share_sync_mean": mean([r["synchronous"]["idle_share"] for r in gen]),
        "generated_idle_share_event_mean": mean([r["event"]["idle_share"] for r in gen]),
        "generated_event_gap_max": max((r["event"]["gap"] for r in gen), default=math.inf),
        "generated_zero_shot_event": summary_of([r["event"]["zero_shot"] for r in gen]),
        "generated_finetuned_event": summary_of([r["event"]["finetuned"] for r in gen if "finetuned" in r["event"]]),
        "generated_zero_shot_sync": summary_of([r["synchronous"]["zero_shot"] for r in gen]),
    }
    site16 = by_name.get("site_16r")
    headline: List[Dict[str, Any]] = []
    if site16:
        headline += [
            {"figure": "site_16r: event best / synchronous best", "unit": "",
             "value": round(site16["event_over_sync"], 4), "goal": f"<= {GOALS['site_16r_event_over_sync']}"},
            {"figure": "site_16r: event reference gap", "unit": "%", "value": round(100 * site16["event"]["gap"], 2),
             "goal": f"<= {100 * GOALS['gap']:g} within 120 s"},
            {"figure": "site_16r: event reference wall time", "unit": "s",
             "value": round(site16["event"]["reference_s"], 1), "goal": "<= 120"},
            {"figure": "site_16r: idle share, event (synchronous beside it in the file)", "unit": "%",
             "value": round(100 * site16["event"]["idle_share"], 2), "goal": f"< {100 * GOALS['idle_share_16x32']:g}"},
            {"figure": "site_16r: idle share, synchronous", "unit": "%",
             "value": round(100 * site16["synchronous"]["idle_share"], 2), "goal": ""},
        ]
    if gen:
        headline += [
            {"figure": f"generated ({len(gen)}): event best / synchronous best, mean", "unit": "",
             "value": round(figures["generated_event_over_sync_mean"], 4), "goal": ""},
            {"figure": "generated: idle share synchronous / event, mean", "unit": "%",
             "value": f"{100 * figures['generated_idle_share_sync_mean']:.1f} / "
                      f"{100 * figures['generated_idle_share_event_mean']:.1f}", "goal": ""},
        ]
    for name in ("lab_2r", "lab_4r", "site_8r", "site_16r"):
        ros = by_name.get(name, {}).get("ros", {})
        for mode in DECISION_MODES:
            if "ratio" in ros.get(mode, {}):
                run = ros[mode]
                headline.append({"figure": f"{name} in ROS, {mode}: the reference plan's makespan / the embedded plan's "
                                           f"({'complete, in order' if run['complete'] and run['logic_consistent'] else 'NOT complete in order'})",
                                 "unit": "", "value": round(run["ratio"], 4), "goal": "<= 1.10" if mode == "event" else ""})
    for name in ("site_8r", "site_16r"):
        if name in by_name and "finetuned" in by_name[name]["event"]:
            headline.append({"figure": f"{name}: the generalist fine-tuned, event / event best known", "unit": "",
                             "value": round(by_name[name]["event"]["finetuned"], 4), "goal": f"<= {GOALS['learned']}"})
            headline.append({"figure": f"{name}: the generalist zero-shot, event / event best known", "unit": "",
                             "value": round(by_name[name]["event"]["zero_shot"], 4), "goal": ""})
    if figures["generated_finetuned_event"]["n"]:
        headline.append({"figure": "generated: the generalist fine-tuned, event / event best known, mean", "unit": "",
                         "value": round(figures["generated_finetuned_event"]["mean"], 4),
                         "goal": f"<= {GOALS['learned']}"})
    if gen:
        headline.append({"figure": "generated: the generalist zero-shot, event / event best known, mean", "unit": "",
                         "value": round(figures["generated_zero_shot_event"]["mean"], 4), "goal": ""})
    return {"headline": headline, "figures": figures, "rows": rows,
            "settings": {"generated": args.generated, "robots": list(args.robots), "tasks": list(args.tasks),
                         "seed": args.seed, "reference_seconds": args.reference_seconds,
                         "finetune_seconds": args.finetune_seconds, "finetune_modes": args.finetune_modes}}


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        result = bench(args, log=lambda line: print(line, file=sys.stderr, flush=True))
    except (ScenarioError, ConfigError, GeneratorError) as error:
        print(f"bench_event: {error}", file=sys.stderr)
        return 2
    write_result(args.out / "bench_event.json", result)
    for row in result["headline"]:
        print(f"{row['figure']}: {row['value']} {row['unit']} (goal {row['goal'] or '-'})")
    return 0
