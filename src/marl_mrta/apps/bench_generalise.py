"""Benchmark: the shipped generalist on scenarios it never saw, zero-shot and after a minute of fine-tuning.

Test scenarios are drawn by model/generator.py from a seed no training run uses (`--seed`),
`--robots` x `--tasks` in size; the lab scenarios are added. Per scenario:
- the reference: the best known plan and the proven lower bound (baselines/reference.py, CP-SAT
  limited to `--reference-seconds` per model); every ratio below is a makespan ÷ that bound;
- zero-shot: the generalist's greedy episode (embedded, ideal), and its time per decision;
- zero-shot with lookahead: the robots' own actors, each looking ahead before it answers
  (evaluation/lookahead.py, config/task_baselines.yaml's budget, with the rollout plan below as
  its opening), no training, and the wall time of one robot's decision, the opening's included;
- zero-shot with rollout: the generalist's rollout plan (evaluation/rollout.py, the budget of
  config/task_baselines.yaml: the best of its eight orientations of the floor), no training
  either, its planning time, and the rollout's plan on the floor as it is alone (the lookahead's
  opening, when it has one with the same budget: the same plan, made once);
- the GA's plan and its planning time;
- on the first `--finetune` test scenarios and the lab ones: `train --init generalist` (preset
  finetune: one minute of wall time) and its best greedy episode;
- on the first `--mappo` test scenarios: per-scenario MAPPO from new weights (`--mappo-preset`,
  default tuned, train's default, within `--mappo-seconds`).
An episode that is not complete and logic-consistent counts as a failure (ratio inf, listed).
Writes <out>/bench_generalise.json (headline figures first, tools/bench_table.py).

  rosrun marl_mrta bench_generalise [--out results] [--policy generalist] [--scenarios 100] [--seed 9]
      [--robots 2 4] [--tasks 4 12] [--layout my_floor.yaml] [--finetune 10] [--mappo 3] [--reference-seconds 10]
With `--mappo 2` it took 56 min of wall time on 2 cores (per scenario 20 s the lookahead's, its
opening rollout plan's 11 s among them); the defaults (`--mappo 3`) take 5 min more.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence

import numpy as np
import torch

from marl_mrta.apps.train_generalist import LAB_SCENARIOS, generated_scenarios, greedy_run as zero_shot
from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import package_root
from marl_mrta.common.results import write_result
from marl_mrta.env.settings import load_task_settings
from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.lookahead import Lookahead
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.robot_actor import in_process_team
from marl_mrta.evaluation.rollout import rollout_plan
from marl_mrta.evaluation.training import offer_teacher_plan, on_new_env
from marl_mrta.mappo.config import load_config, resolve_preset
from marl_mrta.mappo.policy import PolicyFileError, SetActorPolicy, load_policy, read_actor_file
from marl_mrta.mappo.runner import RunError, Runner
from marl_mrta.mappo.training_env import embedded_factory, set_view_pool
from marl_mrta.model.generator import LAYOUT_HELP, GeneratorError
from marl_mrta.model.scenario import Scenario, ScenarioError, load_scenario

#: Goals of the issue, by figure.
GOALS = {"zero_shot_mean": 1.10, "finetuned_mean": 1.03}


def looking_ahead(policy: SetActorPolicy, scenario: Scenario, mask: str, budget) -> Dict[str, Any]:
    """The robots' own actors looking ahead, one episode (embedded, ideal): its makespan (inf:
    not complete in precedence order), the robots' decisions in it, and the rollout plan they
    made at its first step (None: the budget has no opening, or none was found) with its time."""
    bound = policy.for_scenario(scenario)
    lookahead = Lookahead(bound, budget)
    record = run_episode(make_env(scenario, "embedded", mask=mask), in_process_team(bound, lookahead), seed=0)
    return {"makespan": record.makespan if record.complete and record.logic_consistent else math.inf,
            "decisions": max(1, record.decision_steps * scenario.n_robots),
            "opening": lookahead.opening, "opening_s": lookahead.opening_s}


def trained(scenario: Scenario, preset: str, seconds: float, seed: int, init: str, work: Path,
            decision_mode: str = "synchronous") -> Dict[str, float]:
    """MAPPO on one scenario within `seconds` of training wall time (the preset's other budgets
    too), from the actor file `init` ("" : new weights), in `decision_mode`: the greedy makespan of
    the actor the run leaves (its best evaluation with keep_best, else its last)."""
    config = load_config(resolve_preset(preset), {"max_wall_seconds": seconds, "decision_mode": decision_mode})
    make = embedded_factory(scenario, config)
    pool = set_view_pool(config, [scenario], seed) if config.actor == "set" else None
    runner = Runner(config, make, evaluate=on_new_env(make), scenario=str(scenario.source), seed=seed,
                    out_dir=work, log=lambda line: None, tensorboard=False, plots=False, pool=pool, init_actor=init)
    runner.start()
    offer_teacher_plan(runner, log=lambda line: None)
    summary = runner.run()
    evaluations = runner.history["evaluations"]
    last = evaluations[-1]["consistent_makespan"] if evaluations else math.inf
    makespan = runner.best_makespan if config.keep_best else last
    return {"makespan": makespan if math.isfinite(makespan) else math.inf, "wall_s": summary.wall_time,
            "updates": summary.updates}


def ratio(makespan: Optional[float], bound: float) -> float:
    """makespan ÷ bound; inf for no plan (None or inf)."""
    return makespan / bound if makespan is not None and math.isfinite(makespan) and bound > 0 else math.inf


def summary_of(ratios: Sequence[float]) -> Dict[str, Any]:
    """Mean and p90 over the finished ones, and the failures (inf) counted apart."""
    finite = [r for r in ratios if math.isfinite(r)]
    return {"n": len(ratios), "failed": len(ratios) - len(finite),
            "mean": float(np.mean(finite)) if finite else math.inf,
            "p90": float(np.percentile(finite, 90)) if finite else math.inf,
            "max": max(finite) if finite else math.inf}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bench_generalise", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=package_root() / "results", help="directory of bench_generalise.json")
    parser.add_argument("--policy", default="generalist", help="set actor file, or the shipped generalist (default)")
    parser.add_argument("--scenarios", type=int, default=100, help="generated test scenarios (default 100)")
    parser.add_argument("--seed", type=int, default=9, help="seed of the test scenarios (default 9; training uses 0 and 1)")
    parser.add_argument("--robots", type=int, nargs=2, default=(2, 4), metavar=("MIN", "MAX"), help="team sizes (default 2 4)")
    parser.add_argument("--tasks", type=int, nargs=2, default=(4, 12), metavar=("MIN", "MAX"), help="task counts (default 4 12)")
    parser.add_argument("--layout", default=None,
                        help=f"map of the test scenarios: {LAYOUT_HELP}; default: drawn per scenario")
    parser.add_argument("--finetune", type=int, default=10,
                        help="test scenarios (the first ones) also fine-tuned, besides the lab ones (default 10)")
    parser.add_argument("--finetune-seconds", type=float, default=60.0, help="fine-tuning wall time (default 60)")
    parser.add_argument("--mappo", type=int, default=3, help="test scenarios trained per scenario from new weights (default 3)")
    parser.add_argument("--mappo-preset", default="tuned", help="preset of the per-scenario runs (default tuned)")
    parser.add_argument("--mappo-seconds", type=float, default=300.0, help="their wall time (default 300)")
    parser.add_argument("--reference-seconds", type=float, default=10.0,
                        help="CP-SAT deterministic s per model of the reference (default 10)")
    return parser


def bench(args: argparse.Namespace, log: Callable[[str], None] = print) -> Dict[str, Any]:
    torch.set_num_threads(1)   # as training runs (runner.make_deterministic): small networks, timed decisions
    path, data = read_actor_file(args.policy)
    policy = load_policy(path)
    if not isinstance(policy, SetActorPolicy):
        raise PolicyFileError(f"{path}: not a set actor: the benchmark needs one that acts on any scenario")
    mask = str(data["settings"].get("action_mask", "finished"))
    settings = load_baseline_settings().with_cpsat(time_limit=args.reference_seconds)
    task = load_task_settings()
    rows: List[Dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="bench_generalise_") as tmp:
        work = Path(tmp)
        tests = generated_scenarios(args.scenarios, args.seed, work / "scenarios", "test",
                                    tuple(args.robots), tuple(args.tasks), args.layout)
        labs = [load_scenario(package_root() / "scenarios" / f"{name}.xml") for name in LAB_SCENARIOS]
        for k, scenario in enumerate(labs + tests):
            lab = k < len(labs)
            own = task.for_scenario(scenario)   # the scenario's own goal timeout over config/task.yaml's
            instance = scheduling_instance(scenario, own.min_step, own.goal_timeout)
            started = time.perf_counter()
            ga = solve_ga(instance, settings.ga, seed=0)
            ga_s = time.perf_counter() - started
            reference = solve_reference(instance, settings, candidates=[ga])
            bound = reference.lower_bound
            shot = zero_shot(policy, scenario, mask)
            started = time.perf_counter()
            looked = looking_ahead(policy, scenario, mask, settings.lookahead)
            lookahead_s = time.perf_counter() - started
            # The lookahead's opening is the rollout plan (the same budget): made once, timed in both.
            rolled, rollout_s = looked["opening"], looked["opening_s"]
            if rolled is None or settings.lookahead.opening != settings.rollout:
                started = time.perf_counter()
                rolled = rollout_plan(policy, scenario, instance, settings.rollout, mask)
                rollout_s = time.perf_counter() - started
            row: Dict[str, Any] = {
                "scenario": scenario.name if lab else f"test_{k - len(labs):03d}", "lab": lab,
                "robots": scenario.n_robots, "tasks": scenario.n_tasks, "best": reference.best_makespan,
                "bound": bound, "proven_optimal": reference.proven_optimal,
                "zero_shot": ratio(shot["makespan"], bound), "decision_ms": shot["decision_ms"],
                "lookahead": ratio(looked["makespan"], bound), "lookahead_s": lookahead_s,
                "lookahead_decision_s": lookahead_s / looked["decisions"],
                "rollout": ratio(rolled.usable_makespan, bound),
                "rollout_s": rollout_s, "rollout_play_outs": rolled.details["play_outs"],
                "rollout_orientation": rolled.details["orientation"],
                "rollout_as_it_is": ratio(rolled.details["orientation_makespans"][0], bound),
                "ga": ratio(ga.usable_makespan, bound), "ga_s": ga_s}
            index = k - len(labs)
            if lab or index < args.finetune:
                tuned = trained(scenario, "finetune", args.finetune_seconds, 0, str(path), work / f"ft_{k}")
                row["finetuned"], row["finetune_wall_s"] = ratio(tuned["makespan"], bound), tuned["wall_s"]
            if not lab and index < args.mappo:
                own = trained(scenario, args.mappo_preset, args.mappo_seconds, 0, "", work / f"mappo_{k}")
                row["mappo"], row["mappo_wall_s"] = ratio(own["makespan"], bound), own["wall_s"]
            rows.append(row)
            extra = "".join(f", {key} {row[key]:.3f}" for key in ("finetuned", "mappo") if key in row)
            log(f"{k + 1}/{len(labs) + len(tests)} {row['scenario']} {row['robots']}x{row['tasks']}: bound "
                f"{bound:.2f} s{'' if row['proven_optimal'] else ' (gap ' + format(100 * reference.gap, '.1f') + ' %)'}, "
                f"zero-shot {row['zero_shot']:.3f}, lookahead {row['lookahead']:.3f}, rollout {row['rollout']:.3f}, GA {row['ga']:.3f}{extra}")
    test_rows = [r for r in rows if not r["lab"]]
    lab_rows = [r for r in rows if r["lab"]]
    figures = {
        "zero_shot": summary_of([r["zero_shot"] for r in test_rows]),
        "finetuned": summary_of([r["finetuned"] for r in test_rows if "finetuned" in r]),
        "lookahead": summary_of([r["lookahead"] for r in test_rows]),
        "rollout": summary_of([r["rollout"] for r in test_rows]),
        "rollout_as_it_is": summary_of([r["rollout_as_it_is"] for r in test_rows]),
        "ga": summary_of([r["ga"] for r in test_rows]),
        "mappo": summary_of([r["mappo"] for r in test_rows if "mappo" in r]),
        "ga_on_finetuned_ones": summary_of([r["ga"] for r in test_rows if "finetuned" in r]),
        "zero_shot_on_mappo_ones": summary_of([r["zero_shot"] for r in test_rows if "mappo" in r]),
        "lab_zero_shot": {r["scenario"]: r["zero_shot"] for r in lab_rows},
        "lab_lookahead": {r["scenario"]: r["lookahead"] for r in lab_rows},
        "lab_rollout": {r["scenario"]: r["rollout"] for r in lab_rows},
        "lookahead_s_mean": float(np.mean([r["lookahead_s"] for r in rows])),
        "lookahead_decision_s_mean": float(np.mean([r["lookahead_decision_s"] for r in rows])),
        "lookahead_decision_s_max": float(np.max([r["lookahead_decision_s"] for r in rows])),
        "lab_finetuned": {r["scenario"]: r.get("finetuned", math.inf) for r in lab_rows},
        "rollout_s_mean": float(np.mean([r["rollout_s"] for r in rows])),
        "rollout_s_max": float(np.max([r["rollout_s"] for r in rows])),
        "ga_s_mean": float(np.mean([r["ga_s"] for r in rows])),
        "decision_ms_mean": float(np.mean([r["decision_ms"] for r in rows])),
        "proven_optimal_bounds": sum(r["proven_optimal"] for r in test_rows),
    }
    stored = path.with_suffix(".json")   # a shipped actor's training summary (train_generalist's generalist.json)
    training = json.loads(stored.read_text()).get("seconds", {}) if stored.is_file() else {}
    headline = [
        {"figure": f"zero-shot / best bound, mean over {len(test_rows)} unseen scenarios", "unit": "",
         "value": round(figures["zero_shot"]["mean"], 4), "goal": f"<= {GOALS['zero_shot_mean']} and <= GA"},
        {"figure": "zero-shot / best bound, p90", "unit": "", "value": round(figures["zero_shot"]["p90"], 4), "goal": ""},
        {"figure": "zero-shot failures (incomplete or inconsistent)", "unit": "", "value": figures["zero_shot"]["failed"],
         "goal": "0"},
        {"figure": "zero-shot, the robots' own decisions with lookahead (no training) / best bound, mean", "unit": "",
         "value": round(figures["lookahead"]["mean"], 4), "goal": f"<= {GOALS['zero_shot_mean']} and <= GA"},
        {"figure": "zero-shot with lookahead / best bound, p90", "unit": "", "value": round(figures["lookahead"]["p90"], 4),
         "goal": ""},
        {"figure": "zero-shot with lookahead failures (incomplete or inconsistent)", "unit": "",
         "value": figures["lookahead"]["failed"], "goal": "0"},
        {"figure": "zero-shot with rollout (no training) / best bound, mean", "unit": "",
         "value": round(figures["rollout"]["mean"], 4), "goal": f"<= {GOALS['zero_shot_mean']} and <= GA"},
        {"figure": "zero-shot with rollout / best bound, p90", "unit": "", "value": round(figures["rollout"]["p90"], 4),
         "goal": ""},
        {"figure": "zero-shot with rollout on the floor as it is alone / best bound, mean", "unit": "",
         "value": round(figures["rollout_as_it_is"]["mean"], 4), "goal": ""},
        {"figure": "GA / best bound, mean", "unit": "", "value": round(figures["ga"]["mean"], 4), "goal": ""},
    ]
    # A part not run (--finetune 0, --mappo 0) has no figure, rather than a mean of nothing.
    if figures["finetuned"]["n"]:
        headline.append({"figure": f"after {args.finetune_seconds:g} s of fine-tuning / best bound, mean of "
                                   f"{figures['finetuned']['n']}", "unit": "",
                         "value": round(figures["finetuned"]["mean"], 4), "goal": f"<= {GOALS['finetuned_mean']}"})
    if figures["mappo"]["n"]:
        headline.append({"figure": f"per-scenario MAPPO ({args.mappo_preset}, {args.mappo_seconds:g} s) / best bound, "
                                   f"mean of {figures['mappo']['n']}", "unit": "",
                         "value": round(figures["mappo"]["mean"], 4), "goal": ""})
    headline += [
        {"figure": "lab zero-shot / optimum, worst of lab_2r/3r/4r", "unit": "",
         "value": round(max(figures["lab_zero_shot"].values()), 4), "goal": "1.0"},
        {"figure": "lab zero-shot with lookahead / optimum, worst of lab_2r/3r/4r", "unit": "",
         "value": round(max(figures["lab_lookahead"].values()), 4), "goal": "1.0"},
        {"figure": "time per decision step of the team", "unit": "ms", "value": round(figures["decision_ms_mean"], 2),
         "goal": ""},
        {"figure": "time per robot decision with lookahead, mean", "unit": "s",
         "value": round(figures["lookahead_decision_s_mean"], 3), "goal": ""},
        {"figure": "time per robot decision with lookahead, worst scenario's mean", "unit": "s",
         "value": round(figures["lookahead_decision_s_max"], 3), "goal": ""},
        {"figure": "rollout planning time per scenario, mean", "unit": "s", "value": round(figures["rollout_s_mean"], 2),
         "goal": ""},
        {"figure": "GA planning time per scenario, mean", "unit": "s", "value": round(figures["ga_s_mean"], 2), "goal": ""},
    ]
    if training.get("total_s") is not None:
        headline.append({"figure": "training time of the generalist", "unit": "s", "value": training["total_s"], "goal": ""})
    result = {"headline": headline, "figures": figures, "policy": str(path), "generalist_training": training,
              "settings": {k: (list(v) if isinstance(v, tuple) else (str(v) if isinstance(v, Path) else v))
                           for k, v in vars(args).items()},
              "rows": rows, "machine": {"cpu_count": os.cpu_count(), "python": platform.python_version()}}
    write_result(args.out / "bench_generalise.json", result)
    for row in headline:
        log(f"{row['figure']}: {row['value']} {row['unit']} (goal {row['goal'] or '-'})")
    return result


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.scenarios < 1:
            raise ConfigError("--scenarios: at least 1")
        bench(args)
    except (ConfigError, ScenarioError, GeneratorError, RunError, PolicyFileError) as error:
        print(f"bench_generalise: {error}", file=sys.stderr)
        return 2
    return 0
