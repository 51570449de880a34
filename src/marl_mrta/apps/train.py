"""Train MAPPO on a scenario; resumable (scripts/train, rl_manager train).

Backends: embedded (the embedded executor, vectorised) and ros (K arenas of one simulator,
each run by its own rl_task_allocation_manager, stepped in parallel: launch/train.launch).
Bad input (settings file, scenario, run directory, a manager that does not match) ends with
one line on stderr and exit 2.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional

from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import package_root, runs_dir
from marl_mrta.env.settings import DECISION_MODES, load_task_settings
from marl_mrta.evaluation.training import in_pool, offer_teacher_plan, on_new_env
from marl_mrta.mappo.config import MappoConfig, config_from_dict, load_config, resolve_preset
from marl_mrta.mappo.runner import RunError, Runner
from marl_mrta.mappo.training_env import embedded_factory, set_view_pool
from marl_mrta.model.goal_timeout import TimeoutValue, check_goal_timeout
from marl_mrta.model.scenario import ScenarioError, load_scenario

#: The preset of a run without --preset: an actor file (--init, default the shipped generalist)
#: fine-tuned on the scenario for a minute, which holds up on scenarios no preset was tuned on
#: (docs/guide/training.md).
FINETUNE_PRESET = "finetune"
#: ... but with --init none (new weights) or the ros backend: the tuned preset's MLP actor
#: (config/mappo/tuned.yaml), which learns the lab fastest.
NEW_WEIGHTS_PRESET = "tuned"
#: Backends an environment can be built with by this command.
BACKENDS = ("embedded", "ros")
#: Errors of user input; each prints as one line.
INPUT_ERRORS = (ScenarioError, ConfigError, RunError)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="train", description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=None,
                        help="scenario XML (default: the package's scenarios/lab_2r.xml; ros: the managers' scenario, "
                             "checked when given)")
    parser.add_argument("--preset", default=None,
                        help="tuned | sequential | paper | set | finetune | path to a YAML of MAPPO settings "
                             "(default finetune: the shipped generalist fine-tuned for a minute; tuned with "
                             "--init none or --backend ros; set: the set actor, any scenario size; see config/mappo/)")
    parser.add_argument("--backend", choices=BACKENDS, default="embedded",
                        help="embedded: the embedded executor; ros: running task managers in the ROS simulation")
    parser.add_argument("--arenas", type=int, default=None,
                        help="ros: arenas (task managers) to train on in parallel; sets n_envs (default 2)")
    parser.add_argument("--manager-wait", type=float, default=120.0,
                        help="ros: wall s to wait for every arena's task manager (default 120)")
    parser.add_argument("--decision-mode", default=None, metavar="MODE",
                        help="synchronous (the paper's steps) or event (a robot decides when it comes free); "
                             "default: config/task.yaml's (a resumed run: its own)")
    parser.add_argument("--goal-timeout", default=None, metavar="auto|S",
                        help="s a goal may take before it fails, or auto (each leg its own, from its nominal travel "
                             "time) (default: the scenario's <episode goal_timeout>, else config/task.yaml's; ros: "
                             "the managers', checked when given)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override one setting of the preset (YAML value), e.g. --set total_env_steps=2000")
    parser.add_argument("--seed", type=int, default=None, help="seed of everything random in the run (default 0)")
    parser.add_argument("--out", default=None,
                        help="run directory (default: the package's results/runs/<scenario>_<preset>_s<seed>)")
    parser.add_argument("--resume", action="store_true",
                        help="continue the run in --out from its checkpoint (its stored settings and seed)")
    parser.add_argument("--init", default=None, metavar="ACTOR",
                        help="start from a set actor's file (actor.pt of a run with actor: set) or the shipped "
                             "`generalist`, fine-tuning it on the scenario (settings with actor: set; without "
                             "--preset the finetune preset: a minute); none: new weights (default: the preset's "
                             "init_actor)")
    return parser


def parse_overrides(items: List[str]) -> Dict[str, Any]:
    """--set KEY=VALUE items as settings (values parsed as YAML: 3, 2e-3, true, {nav: {best: 0}})."""
    import yaml
    overrides = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--set: {item!r} is not KEY=VALUE")
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError:
            raise ConfigError(f"--set: {key.strip()}: {text!r} is not a YAML value") from None
        if isinstance(value, str):
            try:
                value = float(value)   # YAML 1.1 reads 2e-3 as a string
            except ValueError:
                pass
        overrides[key.strip()] = value
    return overrides


def _settings(args: argparse.Namespace, preset: str, fresh: bool = True) -> MappoConfig:
    """The preset with --set, --decision-mode and (ros) the number of arenas applied; a fresh run
    without --decision-mode trains in config/task.yaml's."""
    overrides = parse_overrides(args.set)
    if args.decision_mode is not None:
        if args.decision_mode not in DECISION_MODES:
            raise ConfigError(f"--decision-mode: {args.decision_mode!r} is not one of {', '.join(DECISION_MODES)}")
        overrides["decision_mode"] = args.decision_mode
    elif fresh and "decision_mode" not in overrides and "decision_mode" not in _preset_keys(preset):
        overrides["decision_mode"] = load_task_settings().decision_mode
    if args.backend == "ros":
        overrides["n_envs"] = args.arenas or 2
    elif args.arenas is not None:
        raise RunError("--arenas: only with --backend ros")
    return load_config(resolve_preset(preset), overrides)


def _goal_timeout(args: argparse.Namespace) -> Optional[TimeoutValue]:
    """--goal-timeout: seconds or 'auto', None when not given; ConfigError (one line) when bad."""
    return check_goal_timeout(args.goal_timeout, "--goal-timeout")


def _backend(args: argparse.Namespace, config: MappoConfig, seed: int, scenario: Optional[str]) -> Dict[str, Any]:
    """Runner arguments of the chosen backend (environments and their greedy evaluation) and the
    scenario it runs."""
    goal_timeout = _goal_timeout(args)
    if args.backend == "ros":
        if config.actor == "set":
            raise RunError("--backend ros: the set actor trains on the embedded backend (actor: set); "
                           "check it in ROS with evaluate.launch method:=policy")
        from marl_mrta.ros.arena_pool import arena_pool
        pool, scenario = arena_pool(config, seed, scenario, args.manager_wait, goal_timeout)
        return {"make_env": None, "pool": pool, "evaluate": in_pool(pool), "scenario": scenario}
    # The command line's goal timeout over the scenario's and config/task.yaml's: the environments
    # are built on the scenario carrying it (make_env takes a scenario's own over the file's).
    loaded = load_scenario(scenario) if goal_timeout is not None else scenario
    if goal_timeout is not None:
        loaded = dataclasses.replace(loaded, goal_timeout=goal_timeout)
    make_env = embedded_factory(loaded, config)
    if config.actor == "set":
        return {"make_env": make_env, "evaluate": on_new_env(make_env), "scenario": scenario,
                "pool": set_view_pool(config, [loaded], seed)}
    return {"make_env": make_env, "evaluate": on_new_env(make_env), "scenario": scenario}


def _resumed_runner(args: argparse.Namespace, log: Callable[[str], None]) -> Runner:
    if args.out is None:
        raise RunError("--out: needed with --resume (the run directory to continue)")
    stored = Runner.read_checkpoint(Path(args.out) / "checkpoint.pt")
    config = config_from_dict(stored["config"], f"{args.out}/checkpoint.pt")
    # A resumed run keeps its settings; contradicting arguments are an error, not ignored.
    if args.seed is not None and args.seed != stored["seed"]:
        raise RunError(f"--seed: {args.seed} differs from the run's seed {stored['seed']}; resume keeps the stored one")
    if args.init is not None:
        raise RunError("--init: a resumed run continues from its checkpoint; --init starts a new one")
    if args.preset is not None or args.set or args.decision_mode:
        wanted = _settings(args, args.preset or default_preset(args), fresh=False)
        if not args.decision_mode:   # unnamed, the run's own
            wanted = dataclasses.replace(wanted, decision_mode=config.decision_mode)
        if wanted != config:
            raise RunError(f"--preset/--set/--decision-mode: the settings differ from those stored in "
                           f"{args.out}/checkpoint.pt")
    if args.backend == "ros" and args.arenas is not None and args.arenas != config.n_envs:
        raise RunError(f"--arenas: {args.arenas} differs from the run's {config.n_envs} environments")
    backend = _backend(args, config, stored["seed"], stored["scenario"])
    runner = Runner.resume(Path(args.out), backend["make_env"], evaluate=backend["evaluate"], log=log,
                           pool=backend.get("pool"))
    note = " (running episodes restart: a simulation is not replayed)" if args.backend == "ros" else ""
    log(f"train: resuming {args.out} at update {runner.update}/{config.n_updates}{note}")
    return runner


def _preset_keys(preset: str) -> set:
    """The settings a preset file names itself."""
    import yaml
    try:
        return set(yaml.safe_load(resolve_preset(preset).read_text()) or {})
    except (OSError, yaml.YAMLError, ConfigError):
        return set()   # load_config reports the problem


def default_preset(args: argparse.Namespace) -> str:
    """The preset of a run without --preset."""
    return NEW_WEIGHTS_PRESET if args.init == "none" or args.backend == "ros" else FINETUNE_PRESET


def _fresh_runner(args: argparse.Namespace, log: Callable[[str], None]) -> Runner:
    preset = args.preset or default_preset(args)
    seed = 0 if args.seed is None else args.seed
    config = _settings(args, preset)
    scenario_arg = args.scenario if args.scenario is not None else (
        None if args.backend == "ros" else str(package_root() / "scenarios" / "lab_2r.xml"))
    scenario = str(Path(scenario_arg).resolve()) if scenario_arg is not None else None
    backend = _backend(args, config, seed, scenario)
    scenario = backend["scenario"]
    suffix = f"_ros{config.n_envs}" if args.backend == "ros" else ""
    run_name = f"{Path(scenario).stem}_{Path(preset).stem}{suffix}_s{seed}"
    out = Path(args.out) if args.out else runs_dir() / run_name
    init = None if args.init is None else ("" if args.init == "none" else args.init)
    runner = Runner(config, backend["make_env"], evaluate=backend["evaluate"], scenario=scenario, seed=seed,
                    out_dir=out, log=log, pool=backend.get("pool"), init_actor=init)
    runner.start()
    where = f"{config.n_envs} ROS arenas" if args.backend == "ros" else f"{config.n_envs} embedded environments"
    started_from = config.init_actor if init is None else init
    start = f", starting from {started_from}" if started_from else ""
    log(f"train: {scenario} with preset {preset}, seed {seed}{start}, {config.n_updates} updates of "
        f"{config.batch_size} steps on {where} -> {out}")
    offer_teacher_plan(runner, log)
    return runner


def main(argv: Optional[List[str]] = None, log: Callable[[str], None] = print) -> int:
    args = build_parser().parse_args(argv)
    lost: tuple = ()
    if args.backend == "ros":
        from marl_mrta.ros.env_client import ManagerUnavailable
        lost = (ManagerUnavailable,)
    try:
        runner = _resumed_runner(args, log) if args.resume else _fresh_runner(args, log)
        summary = runner.run()
    except INPUT_ERRORS as error:
        print(f"train: {error}", file=sys.stderr)
        return 2
    except lost as error:   # a manager or the simulator went away; the last checkpoint stands
        print(f"train: {error}", file=sys.stderr)
        return 1
    except OSError as error:   # e.g. an output directory that cannot be written
        print(f"train: {error.filename or ''}: {error.strerror}", file=sys.stderr)
        return 2
    log(f"train: {summary.updates} updates, {summary.env_steps} steps, {summary.episodes} episodes in "
        f"{summary.wall_time:.1f} s; {summary.greedy_result()}; "
        f"actor {runner.actor_path}")
    return 0
