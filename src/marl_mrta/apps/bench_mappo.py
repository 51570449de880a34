"""`scripts/bench_mappo`: MAPPO's headline figures on lab_2r with the embedded executor.

- time to policy: wall time from the start of training until the greedy policy's makespan is
  within 5 % of the exact solver's proven optimum (`tuned` preset, several seeds);
- environment steps per second: the bare environment, and training (collect + update);
- `paper` against `tuned` on the same budget (the paper's 70 000 decision steps);
- the learned 2-robot allocation beside the paper's and the exact solver's.
Writes <out>/bench_mappo.json; runs go to <out>/tmp/bench_mappo/.
"""
from __future__ import annotations

import argparse
import json
import shutil
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Dict, List, Optional

import numpy as np

from marl_mrta.apps.train import parse_overrides
from marl_mrta.baselines.reference import scenario_reference
from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import package_root
from marl_mrta.common.results import write_result
from marl_mrta.evaluation.training import greedy_episodes, on_new_env
from marl_mrta.mappo.config import MappoConfig, load_config, resolve_preset
from marl_mrta.mappo.env_pool import episode_seed
from marl_mrta.mappo.policy import load_policy
from marl_mrta.mappo.runner import Runner
from marl_mrta.mappo.training_env import embedded_factory

PAPER_ALLOCATION = [["A1", "A2", "B2", "B1"], ["A3", "A4", "B3", "B4"]]
WITHIN = 1.05          # "within 5 % of exact"
PAPER_BUDGET = 70_000  # decision steps, paper Table 7


def exact_plan(env):
    """The exact solver's proven-optimal plan for the environment's scenario and step rules."""
    return scenario_reference(env.scenario, env.settings.min_step)


def env_steps_per_second(make_env, seconds: float = 3.0, seed: int = 0) -> float:
    """Bare environment: uniformly random allowed actions, resets included."""
    env = make_env()
    rng = np.random.default_rng(seed)
    out = env.reset(seed=seed)
    steps, started = 0, time.perf_counter()
    while time.perf_counter() - started < seconds:
        actions = [int(rng.choice(np.flatnonzero(row))) for row in out.action_mask]
        out = env.step(actions)
        steps += 1
        if out.done or out.truncated:
            out = env.reset(seed=seed + steps)
    return steps / (time.perf_counter() - started)


def train(config: MappoConfig, scenario: str, seed: int, out: Path, target: float, stop_at_target: bool,
          log) -> Dict[str, Any]:
    shutil.rmtree(out, ignore_errors=True)
    started = time.perf_counter()
    make_env = embedded_factory(scenario, config)
    runner = Runner(config, make_env, evaluate=on_new_env(make_env), scenario=scenario, seed=seed, out_dir=out,
                    log=lambda line: None, target_makespan=target, stop_at_target=stop_at_target,
                    tensorboard=False, plots=False)
    runner.start()
    summary = runner.run()
    total = time.perf_counter() - started
    evaluations = runner.history["evaluations"]
    result = {
        "seed": seed, "env_steps": summary.env_steps, "updates": summary.updates, "episodes": summary.episodes,
        "train_wall_s": round(summary.wall_time, 2), "process_wall_s": round(total, 2),
        "time_to_policy_s": None if summary.time_to_target is None else round(summary.time_to_target, 2),
        "steps_to_policy": summary.steps_to_target,
        "train_steps_per_s": round(summary.env_steps / summary.wall_time, 1),
        "final_greedy_makespan_s": round(summary.greedy_makespan, 3),
        "best_greedy_makespan_s": round(min(e["makespan"] for e in evaluations), 3) if evaluations else None,
        "actor": str(runner.actor_path),
        "greedy_allocation": learned_allocation(str(runner.actor_path), make_env, 1, 0)["robot_tasks"],
    }
    log(f"  seed {seed}: time to policy {result['time_to_policy_s']} s ({result['steps_to_policy']} steps), "
        f"final greedy {result['final_greedy_makespan_s']} s, {result['train_steps_per_s']} steps/s")
    return result


def learned_allocation(actor_path: str, make_env, episodes: int, seed: int) -> Dict[str, Any]:
    records = greedy_episodes(load_policy(actor_path), make_env(), [episode_seed(seed, 0, k) for k in range(episodes)])
    return {"robot_tasks": records[0].robot_tasks,
            "mean_makespan_s": round(float(np.mean([r.makespan for r in records])), 3),
            "sd_makespan_s": round(float(np.std([r.makespan for r in records])), 3),
            "logic_consistent_pct": 100.0 * float(np.mean([r.logic_consistent for r in records])),
            "collisions_per_episode": float(np.mean([r.collisions for r in records]))}


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="bench_mappo", description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(package_root() / "results"), help="directory of bench_mappo.json (default results)")
    parser.add_argument("--scenario", default=str(package_root() / "scenarios" / "lab_2r.xml"))
    parser.add_argument("--seeds", type=int, default=3, help="seeds of the time-to-policy runs (default 3)")
    parser.add_argument("--budget", type=int, default=PAPER_BUDGET,
                        help=f"decision steps of the paper-vs-tuned comparison (default {PAPER_BUDGET})")
    parser.add_argument("--ros", action="store_true",
                        help="instead: time to policy on the ros backend (minutes; starts its own ROS graph, "
                             "keeps the embedded figures of bench_mappo.json)")
    parser.add_argument("--arenas", type=int, default=2, help="--ros: arenas of the simulator (default 2)")
    parser.add_argument("--ros-minutes", type=float, default=30.0,
                        help="--ros: wall minutes each ros-backend training may take at most (default 30)")
    parser.add_argument("--ros-modes", default="pretrained,scratch",
                        help="--ros: pretrained (embedded training, then ROS) and/or scratch (ROS only)")
    parser.add_argument("--pretrain-seeds", type=int, default=4,
                        help="--ros pretrained: embedded-trained candidates (seeds 0..N-1) checked in ROS in turn (default 4)")
    parser.add_argument("--ros-port", type=int, default=11599, help="--ros: port of the benchmark's own ROS master")
    parser.add_argument("--preset", default="tuned",
                        help="settings of the time-to-policy runs: tuned | sequential | paper | a YAML (default tuned)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override one setting of --preset (YAML value), as scripts/train --set")
    args = parser.parse_args(argv)
    out = Path(args.out)
    runs = out / "tmp" / "bench_mappo"
    log = lambda line: print(line, flush=True)  # noqa: E731
    try:
        chosen = load_config(resolve_preset(args.preset), parse_overrides(args.set))
        tuned = load_config(resolve_preset("tuned"))
        paper = load_config(resolve_preset("paper"))
        make_env = embedded_factory(args.scenario, tuned)
    except (ConfigError, ValueError) as error:
        print(f"bench_mappo: {error}", file=sys.stderr)
        return 2
    env = make_env()
    plan, instance = exact_plan(env)
    target = WITHIN * plan.makespan
    log(f"exact: {plan.makespan:.2f} s (proven {plan.proven_optimal}), allocation {plan.describe(instance.task_ids)}")

    if args.ros:
        return _main_ros(args, chosen, target, out, runs, log)

    bare = env_steps_per_second(make_env)
    log(f"bare environment: {bare:.0f} steps/s")

    log(f"time to policy ({args.preset}, complete, logic-consistent greedy makespan <= {target:.2f} s):")
    fine = replace(chosen, eval_every=1)
    to_policy = [train(fine, args.scenario, seed, runs / f"{args.preset}_s{seed}", target, True, log) for seed in range(args.seeds)]
    times = [r["time_to_policy_s"] for r in to_policy]
    reached = [t for t in times if t is not None]

    log(f"same budget, {args.budget} decision steps:")
    comparison = {}
    # The third run separates the learner's settings from the environment's: the paper's
    # hyperparameters on the tuned preset's masks and reward.
    paper_hparams = replace(paper, action_mask=tuned.action_mask, reward_overrides=tuned.reward_overrides)
    for name, config in (("tuned", tuned), ("paper", paper), ("paper_hyperparameters_tuned_env", paper_hparams)):
        budgeted = replace(config, total_env_steps=args.budget)
        comparison[name] = train(budgeted, args.scenario, 0, runs / f"{name}_budget", target, False, log)
        comparison[name]["ratio_to_exact"] = round(comparison[name]["final_greedy_makespan_s"] / plan.makespan, 4)
        log(f"  {name}: greedy / exact = {comparison[name]['ratio_to_exact']}")

    allocation = learned_allocation(comparison["tuned"]["actor"], make_env, 5, 1)
    noisy_env = embedded_factory(args.scenario, replace(tuned, noise_profile="measured_tb3"))
    noisy = learned_allocation(comparison["tuned"]["actor"], noisy_env, 20, 2)
    log(f"learned allocation {allocation['robot_tasks']} (paper {PAPER_ALLOCATION}); "
        f"under measured_tb3 noise: {noisy['mean_makespan_s']} s, {noisy['logic_consistent_pct']} % logic-consistent")

    median = statistics.median(t if t is not None else float("inf") for t in times)
    rate = round(statistics.median(r["train_steps_per_s"] for r in to_policy), 1)
    result = {
        "scenario": args.scenario,
        "exact": {"makespan_s": plan.makespan, "proven_optimal": plan.proven_optimal,
                  "robot_tasks": plan.describe(instance.task_ids)},
        "env_steps_per_s": {"bare_environment": round(bare, 1),
                            f"training_{args.preset}": rate},
        "time_to_policy": {"criterion": f"complete, logic-consistent greedy makespan <= {WITHIN} x exact", "preset": args.preset,
                           "overrides": args.set,
                           "median_s": median, "runs": to_policy},
        "same_budget": {"env_steps": args.budget, **comparison},
        "allocation": {"learned": allocation, "learned_under_measured_tb3_noise": noisy,
                       "paper": PAPER_ALLOCATION, "exact": plan.describe(instance.task_ids)},
        "headline": [
            {"figure": f"time to policy, embedded, lab_2r (median, {args.preset})", "value": median, "unit": "s", "goal": "<= 60"},
            {"figure": "time-to-policy runs that reached it", "value": f"{len(reached)}/{len(times)}", "unit": "", "goal": ""},
            {"figure": f"training throughput ({args.preset})", "value": rate, "unit": "steps/s", "goal": ""},
            {"figure": "bare embedded environment", "value": round(bare, 1), "unit": "steps/s", "goal": ""},
            {"figure": f"tuned greedy / exact, {args.budget} steps", "value": comparison["tuned"]["ratio_to_exact"], "unit": "", "goal": "<= 1.10"},
            {"figure": f"paper greedy / exact, {args.budget} steps", "value": comparison["paper"]["ratio_to_exact"], "unit": "", "goal": ""},
            {"figure": f"paper hyperparameters, tuned env settings: greedy / exact, {args.budget} steps",
             "value": comparison["paper_hyperparameters_tuned_env"]["ratio_to_exact"], "unit": "", "goal": ""},
        ],
    }
    write_embedded_figures(out / "bench_mappo.json", result)
    log(f"wrote {out / 'bench_mappo.json'}")
    return 0


def write_embedded_figures(path: Path, result: dict) -> None:
    """bench_mappo.json with the embedded figures replaced; the ros-backend ones (`--ros`), not
    measured by this run, stay as they were."""
    earlier = json.loads(path.read_text()) if path.is_file() else {}
    keeps = "ros" in earlier and "provenance" in earlier   # figures of no recorded run are dropped
    if keeps:
        result = dict(result, ros=earlier["ros"],
                      headline=result["headline"] + [row for row in earlier.get("headline", []) if "ros" in row["figure"]])
    write_result(path, result, keeps_earlier=keeps)



def _main_ros(args, tuned: MappoConfig, embedded_target: float, out: Path, runs: Path, log) -> int:
    from marl_mrta.apps.bench_mappo_ros import GraphError, measure, merge_into
    modes = [m.strip() for m in args.ros_modes.split(",") if m.strip()]
    unknown = [m for m in modes if m not in ("pretrained", "scratch")]
    if unknown or not modes:
        print(f"bench_mappo: --ros-modes: {','.join(unknown) or '(empty)'}: not pretrained or scratch", file=sys.stderr)
        return 2
    if args.pretrain_seeds < 1:
        print(f"bench_mappo: --pretrain-seeds: {args.pretrain_seeds}: must be at least 1", file=sys.stderr)
        return 2
    scenario = str(Path(args.scenario).resolve())
    try:
        ros = measure(tuned, scenario, args.arenas, args.ros_minutes, args.ros_port, 0, runs.resolve(),
                      embedded_target, train, modes, log, pretrain_seeds=args.pretrain_seeds)
        ros["preset"], ros["overrides"] = args.preset, args.set
    except GraphError as error:
        print(f"bench_mappo: {error}", file=sys.stderr)
        return 1
    document = merge_into(out / "bench_mappo.json", ros)
    for row in document["headline"]:
        log(f"  {row['figure']}: {row['value']} {row['unit']} {('(goal ' + row['goal'] + ')') if row['goal'] else ''}")
    log(f"wrote {out / 'bench_mappo.json'}")
    return 0
