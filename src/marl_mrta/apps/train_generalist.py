"""`train_generalist`: train a set actor across generated scenarios (policies/generalist.pt is one).

    train_generalist --out results/runs/generalist --scenarios 320 --robots 2 4 --tasks 4 16 --mappo-steps 48000 --seed 0

That command made the shipped file (docs/guide/training.md).
Stages, each seeded and timed; the exact teacher's budget is wall time, so on a loaded machine
the plans, and what is learnt from them, can differ:
1. scenarios: `--scenarios` drawn by model/generator.py, `--robots` 2-8 robots and `--tasks` 4-32
   tasks (the generator draws the map, the tasks, the precedence and the service times), written
   under <out>/scenarios,
   and the package's lab scenarios (--no-lab: not);
2. plans: per scenario the best consistent plan of the GA, the auction and, for teams small enough
   for it, the exact solver within a short budget (baselines/);
3. imitation: the set actor learns those plans' joint actions in the training decision order
   (mappo/imitation.py);
4. MAPPO: the preset's settings (config/mappo/generalist.yaml) on all scenarios at once,
   each environment of the pool running another scenario every episode (mappo/set_view.py),
   starting from the imitation's actor. Every `--check-every` updates the greedy policy runs on
   `--holdout` further generated scenarios; the actor with the best mean ratio to their plans is
   the result (<out>/actor.pt: `evaluate --policy`, `train --preset set --init` take it).
Writes <out>/generalist.json: the stages' wall times, the imitation's and the checks' figures.
Bad input: one line on stderr, exit 2.
"""
from __future__ import annotations

import argparse
import json
import math
import random
import shutil
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from marl_mrta.apps.train import parse_overrides
from marl_mrta.baselines.auction import solve_auction
from marl_mrta.baselines.exact import solve_exact
from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.plan import Plan
from marl_mrta.baselines.reference import choose_solver, scheduling_instance
from marl_mrta.baselines.settings import BaselineSettings, load_baseline_settings
from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import package_root
from marl_mrta.common.results import write_result
from marl_mrta.env.factory import make_env
from marl_mrta.env.settings import load_embedded_settings, load_task_settings
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.policies import LearnedPolicy
from marl_mrta.mappo.config import MappoConfig, config_to_dict, load_config, resolve_preset
from marl_mrta.mappo.imitation import Demonstration, demonstrate, imitate
from marl_mrta.mappo.policy import SetActorPolicy, save_set_actor
from marl_mrta.mappo.runner import RunError, Runner, make_deterministic
from marl_mrta.mappo.set_networks import SetActor
from marl_mrta.mappo.set_view import SetView
from marl_mrta.mappo.training_env import set_view_pool
from marl_mrta.model.generator import (DEFAULT_MAX_LEG, LAYOUT_HELP, MAX_ROBOTS, MAX_TASKS, MIN_ROBOTS, MIN_TASKS,
                                       GeneratorError, ScenarioRequest, generate_scenarios)
from marl_mrta.model.scenario import Scenario, ScenarioError, load_scenario

#: Teams and task counts the generalist is trained on by default (the generator offers 2-16 robots, 4-32 tasks).
TRAIN_ROBOTS = (2, 8)
TRAIN_TASKS = (4, 32)
#: The package's scenarios trained on besides the generated ones (unless --no-lab).
LAB_SCENARIOS = ("lab_2r", "lab_3r", "lab_4r")
#: Seeds tried per scenario before the generator's refusal stands.
GENERATOR_ATTEMPTS = 5
#: s of wall time the exact solver may take on a training scenario's plan (small teams only).
TEACHER_EXACT_SECONDS = 5.0


def generated_scenarios(count: int, seed: int, out_dir: Path, prefix: str,
                        robots: Tuple[int, int] = TRAIN_ROBOTS, tasks: Tuple[int, int] = TRAIN_TASKS,
                        layout: Optional[str] = None) -> List[Scenario]:
    """`count` scenarios, scenario k with a team of robots[0]..robots[1] and tasks[0]..tasks[1] tasks
    drawn from (seed, k) and the rest drawn by the generator (generate_scenarios: layout unless
    given, e.g. a map file of one's own floor, precedence, map size)."""
    model = load_embedded_settings().travel
    max_leg = DEFAULT_MAX_LEG   # the generator's own default (not the goal timeout): the same scenarios as ever
    draw = random.Random(seed)
    scenarios = []
    for k in range(count):
        base = ScenarioRequest(n_robots=draw.randint(*robots), n_tasks=draw.randint(*tasks), max_leg=max_leg,
                               name=f"{prefix}_{k:03d}", **({"layout": layout} if layout else {}))
        for attempt in range(GENERATOR_ATTEMPTS):
            try:   # a draw whose legs exceed the goal timeout is drawn again from the next seed
                scenarios += generate_scenarios(1, seed * 1_000 + k + 100_000 * attempt, out_dir, base, model,
                                                keep=("n_robots", "n_tasks") + (("layout",) if layout else ()))
                break
            except GeneratorError:
                if attempt == GENERATOR_ATTEMPTS - 1:
                    raise
    return scenarios


def teacher_plan(scenario: Scenario, settings: BaselineSettings, seed: int = 0) -> Plan:
    """The best complete, logic-consistent plan of the GA, the auction and (when the team is
    small enough for it) the exact solver within TEACHER_EXACT_SECONDS."""
    task = load_task_settings()
    instance = scheduling_instance(scenario, task.min_step, task.goal_timeout)
    plans = [solve_ga(instance, settings.ga, seed=seed), solve_auction(instance, settings.auction_objective)]
    usable = [p for p in plans if p.usable]
    if choose_solver(instance, settings) == "astar":
        upper = min((p.makespan for p in usable), default=None)
        exact = solve_exact(instance, upper_bound=upper, budget=replace(settings.astar, time_limit=TEACHER_EXACT_SECONDS))
        if exact.usable:
            usable.append(exact)
    if not usable:
        raise ScenarioError(f"{scenario.source}: no consistent plan for imitation")
    return min(usable, key=lambda p: p.makespan)


def plans_for(scenarios: Sequence[Scenario], cache: Path, log: Callable[[str], None]) -> List[Dict[str, Any]]:
    """Teacher plans of the scenarios (makespan and joint actions), cached in `cache` by scenario file."""
    known = json.loads(cache.read_text()) if cache.exists() else {}
    settings = load_baseline_settings()
    plans = []
    for k, scenario in enumerate(scenarios):
        key = Path(scenario.source).name
        if key not in known:
            plan = teacher_plan(scenario, settings)
            known[key] = {"makespan": plan.makespan, "method": plan.method, "joint_actions": plan.joint_actions}
            cache.write_text(json.dumps(known))
            log(f"plan {k + 1}/{len(scenarios)}: {key}: {plan.method} {plan.makespan:.2f} s")
        plans.append(known[key])
    return plans


def greedy_run(policy: SetActorPolicy, scenario: Scenario, mask: str) -> Dict[str, float]:
    """The policy's greedy episode on the scenario (embedded, ideal): its makespan (inf when it
    does not finish every task in precedence order) and the wall time of its decisions in ms per
    decision step of the team."""
    env = make_env(scenario, "embedded", mask=mask)
    learned = LearnedPolicy(policy.for_scenario(scenario), env.n_agents)
    timed = {"seconds": 0.0, "steps": 0}
    act = learned.act

    def timed_act(output):
        started = time.perf_counter()
        actions = act(output)
        timed["seconds"] += time.perf_counter() - started
        timed["steps"] += 1
        return actions

    learned.act = timed_act
    record = run_episode(env, learned, seed=0)
    return {"makespan": record.makespan if record.complete and record.logic_consistent else math.inf,
            "decision_ms": 1000.0 * timed["seconds"] / max(1, timed["steps"])}


def greedy_ratio(policy: SetActorPolicy, scenario: Scenario, reference: float, mask: str) -> float:
    """Greedy makespan of the policy on the scenario ÷ `reference` (inf: a failed episode)."""
    return greedy_run(policy, scenario, mask)["makespan"] / reference


def check(policy: SetActorPolicy, holdout: Sequence[Scenario], references: Sequence[float], mask: str) -> Dict[str, float]:
    """The policy's greedy ratios on the held-out scenarios: mean (failures count 2), worst, failures."""
    ratios = [greedy_ratio(policy, s, r, mask) for s, r in zip(holdout, references)]
    finite = [min(r, 2.0) for r in ratios]
    return {"mean": sum(finite) / len(finite), "worst": max(ratios), "failed": sum(not math.isfinite(r) for r in ratios)}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="train_generalist", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="run directory")
    parser.add_argument("--scenarios", type=int, default=240, help="generated training scenarios (default 240)")
    parser.add_argument("--robots", type=int, nargs=2, default=TRAIN_ROBOTS, metavar=("MIN", "MAX"),
                        help=f"team sizes of the generated scenarios (default {TRAIN_ROBOTS[0]} {TRAIN_ROBOTS[1]})")
    parser.add_argument("--tasks", type=int, nargs=2, default=TRAIN_TASKS, metavar=("MIN", "MAX"),
                        help=f"task counts of the generated scenarios (default {TRAIN_TASKS[0]} {TRAIN_TASKS[1]})")
    parser.add_argument("--layout", default=None,
                        help=f"map of the generated scenarios: {LAYOUT_HELP}; default: drawn per scenario")
    parser.add_argument("--holdout", type=int, default=12, help="generated scenarios that pick the best actor (default 12)")
    parser.add_argument("--seed", type=int, default=0, help="seed of every stage (default 0)")
    parser.add_argument("--preset", default="generalist",
                        help="settings of the network, the imitation's learning rate and the MAPPO stage (default generalist)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override one setting")
    parser.add_argument("--imitation-epochs", type=int, default=60, help="passes over the plans (default 60)")
    parser.add_argument("--imitation-lr", type=float, default=2e-3, help="Adam step size of the imitation (default 2e-3)")
    parser.add_argument("--mappo-steps", type=int, default=40_000,
                        help="decision steps of the MAPPO stage over all environments (default 40000; 0: none)")
    parser.add_argument("--check-every", type=int, default=10, help="updates between checks on the holdout (default 10)")
    parser.add_argument("--no-lab", dest="lab", action="store_false",
                        help="leave the package's lab scenarios out of the training scenarios")
    return parser


def _imitation_stage(config: MappoConfig, scenarios: Sequence[Scenario], plans: Sequence[Dict[str, Any]],
                     epochs: int, learning_rate: float, seed: int,
                     log: Callable[[str], None]) -> Tuple[SetActor, List[Dict[str, float]]]:
    demos: List[Demonstration] = []
    for scenario, plan in zip(scenarios, plans):
        env = make_env(scenario, "embedded", mask=config.action_mask)
        demos.append(demonstrate(env, SetView(scenario, config.turn_order), plan["joint_actions"], config.decision_order,
                                 seed=0))
    make_deterministic(seed)
    actor = SetActor(config.hidden_size, config.set_heads, config.set_layers)
    history = imitate(actor, demos, epochs=epochs, learning_rate=learning_rate, demos_per_batch=16,
                      seed=seed, log=log)
    return actor, history


def _mappo_stage(config: MappoConfig, scenarios: Sequence[Scenario], start: Path, out: Path, seed: int,
                 holdout: Sequence[Scenario], references: Sequence[float], check_every: int,
                 log: Callable[[str], None]) -> Tuple[Dict[str, float], List[Dict[str, Any]]]:
    """MAPPO across the scenarios from the actor file `start`; keeps the best checked actor in
    out/actor.pt. Returns the best check and every check."""
    pool = set_view_pool(config, scenarios, seed)
    runner = Runner(config, None, evaluate=lambda actor, seeds: [], scenario="generated", seed=seed,
                    out_dir=out / "mappo", log=log, tensorboard=False, plots=False, pool=pool, init_actor=str(start))
    runner.start()
    best = check(runner.greedy_policy(), holdout, references, config.action_mask)
    checks = [{"update": 0, "env_steps": 0, **best}]
    log(f"check before MAPPO: mean ratio {best['mean']:.4f}, worst {best['worst']:.3f}, failed {best['failed']}")
    while runner.update < config.n_updates:
        metrics = runner.train_one_update()
        if runner.update % check_every and runner.update < config.n_updates:
            continue
        result = check(runner.greedy_policy(), holdout, references, config.action_mask)
        checks.append({"update": runner.update, "env_steps": runner.env_steps, **result})
        log(f"update {runner.update}/{config.n_updates} | steps {runner.env_steps} | entropy {metrics['entropy']:.2f} | "
            f"check: mean ratio {result['mean']:.4f}, worst {result['worst']:.3f}, failed {result['failed']}")
        if result["mean"] < best["mean"]:
            best = result
            save_set_actor(out / "actor.pt", runner.trainer.actor, settings=config_to_dict(config),
                           trained_on=f"generalist: {len(scenarios)} generated scenarios")
    return best, checks


def train_generalist(args: argparse.Namespace, log: Callable[[str], None] = print) -> Dict[str, Any]:
    config = load_config(resolve_preset(args.preset), {**parse_overrides(args.set), "total_env_steps": max(1, args.mappo_steps)})
    if config.actor != "set":
        raise ConfigError(f"{args.preset}: actor: the generalist is a set actor, the settings give {config.actor}")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    times: Dict[str, float] = {}
    started = time.perf_counter()
    sizes = {"robots": tuple(args.robots), "tasks": tuple(args.tasks), "layout": args.layout}
    scenarios = generated_scenarios(args.scenarios, args.seed, out / "scenarios", "train", **sizes)
    if args.lab:
        scenarios += [load_scenario(package_root() / "scenarios" / f"{name}.xml") for name in LAB_SCENARIOS]
    holdout = generated_scenarios(args.holdout, args.seed + 1, out / "scenarios", "holdout", **sizes)
    times["scenarios_s"] = time.perf_counter() - started
    mark = time.perf_counter()
    plans = plans_for(list(scenarios) + list(holdout), out / "plans.json", log)
    train_plans, references = plans[:len(scenarios)], [p["makespan"] for p in plans[len(scenarios):]]
    times["plans_s"] = time.perf_counter() - mark
    mark = time.perf_counter()
    actor, imitation = _imitation_stage(config, scenarios, train_plans, args.imitation_epochs, args.imitation_lr,
                                        args.seed, log)
    save_set_actor(out / "actor.pt", actor, settings=config_to_dict(config),
                   trained_on=f"generalist: imitation of {len(scenarios)} generated scenarios' plans")
    imitated = check(SetActorPolicy(actor, settings=config_to_dict(config)), holdout, references, config.action_mask)
    log(f"imitation: holdout mean ratio {imitated['mean']:.4f}, worst {imitated['worst']:.3f}, failed {imitated['failed']}")
    times["imitation_s"] = time.perf_counter() - mark
    mark = time.perf_counter()
    best, checks = imitated, []
    if args.mappo_steps > 0:
        start = out / "imitation_actor.pt"
        shutil.copyfile(out / "actor.pt", start)
        best, checks = _mappo_stage(config, scenarios, start, out, args.seed, holdout, references, args.check_every, log)
    times["mappo_s"] = time.perf_counter() - mark
    times["total_s"] = time.perf_counter() - started
    summary = {"scenarios": len(scenarios), "holdout": len(holdout), "seed": args.seed, **sizes, "settings": config_to_dict(config),
               "seconds": {k: round(v, 1) for k, v in times.items()}, "imitation": imitation,
               "imitation_check": imitated, "mappo_checks": checks, "best_check": best}
    write_result(out / "generalist.json", summary)
    log(f"train_generalist: {len(scenarios)} scenarios, {times['total_s']:.0f} s (plans {times['plans_s']:.0f} s, "
        f"imitation {times['imitation_s']:.0f} s, MAPPO {times['mappo_s']:.0f} s); holdout mean ratio "
        f"{best['mean']:.4f}; actor {out / 'actor.pt'}")
    return summary


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.scenarios < 1 or args.holdout < 1:
            raise ConfigError("--scenarios, --holdout: at least 1 each")
        for option, (low, high), (least, most) in (("--robots", args.robots, (MIN_ROBOTS, MAX_ROBOTS)),
                                                    ("--tasks", args.tasks, (MIN_TASKS, MAX_TASKS))):
            if not least <= low <= high <= most:
                raise ConfigError(f"{option}: {low} {high} is not a range within {least}..{most}")
        train_generalist(args)
    except (ConfigError, ScenarioError, GeneratorError, RunError) as error:
        print(f"train_generalist: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"train_generalist: {error.filename or ''}: {error.strerror}", file=sys.stderr)
        return 2
    return 0
