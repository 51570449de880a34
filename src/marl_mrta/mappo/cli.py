"""Train MAPPO on a scenario with the embedded executor; resumable (scripts/train).

Bad input (settings file, scenario, run directory) ends with one line on stderr and exit 2.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from functools import partial
from pathlib import Path
from typing import Callable, List, Optional

from ..env.api import TaskAllocationEnv
from ..env.factory import make_env
from ..scenario import ScenarioError, load_scenario
from ..tasks.config_reader import ConfigError as EnvConfigError
from ..tasks.config_reader import package_root
from .config import ConfigError, MappoConfig, config_from_dict, load_config, resolve_preset
from .runner import RunError, Runner

#: Backends an environment can be built with by this command.
BACKENDS = ("embedded",)
#: Errors of user input; each prints as one line.
INPUT_ERRORS = (ScenarioError, EnvConfigError, ConfigError, RunError)


def env_factory(scenario: str, config: MappoConfig, backend: str = "embedded") -> Callable[[], TaskAllocationEnv]:
    """A function building one environment of the run (the scenario is parsed once)."""
    loaded = load_scenario(scenario)
    if config.reward_overrides:
        # The scenario's own <reward> overrides first, the training settings' on top.
        merged = {section: dict(values) for section, values in loaded.reward_overrides.items()}
        for section, values in config.reward_overrides.items():
            merged.setdefault(section, {}).update(values)
        loaded = dataclasses.replace(loaded, reward_overrides=merged)
    build = partial(make_env, loaded, backend, profile=config.noise_profile, mask=config.action_mask)
    build()   # fail fast on bad settings
    return build


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="train", description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=str(package_root() / "scenarios" / "lab_2r.xml"),
                        help="scenario XML (default: the package's scenarios/lab_2r.xml)")
    parser.add_argument("--preset", default=None,
                        help="tuned | paper | path to a YAML of MAPPO settings (default tuned; see config/mappo/)")
    parser.add_argument("--backend", choices=BACKENDS, default="embedded", help="executor that runs the episodes")
    parser.add_argument("--seed", type=int, default=None, help="seed of everything random in the run (default 0)")
    parser.add_argument("--out", default=None,
                        help="run directory (default: the package's results/runs/<scenario>_<preset>_s<seed>)")
    parser.add_argument("--resume", action="store_true",
                        help="continue the run in --out from its checkpoint (its stored settings and seed)")
    return parser


def _resumed_runner(args: argparse.Namespace, log: Callable[[str], None]) -> Runner:
    if args.out is None:
        raise RunError("--out: needed with --resume (the run directory to continue)")
    stored = Runner.read_checkpoint(Path(args.out) / "checkpoint.pt")
    config = config_from_dict(stored["config"], f"{args.out}/checkpoint.pt")
    # A resumed run keeps its settings; contradicting arguments are an error, not ignored.
    if args.seed is not None and args.seed != stored["seed"]:
        raise RunError(f"--seed: {args.seed} differs from the run's seed {stored['seed']}; resume keeps the stored one")
    if args.preset is not None and load_config(resolve_preset(args.preset)) != config:
        raise RunError(f"--preset: {args.preset} differs from the settings stored in {args.out}/checkpoint.pt")
    runner = Runner.resume(Path(args.out), env_factory(stored["scenario"], config, args.backend), log=log)
    log(f"train: resuming {args.out} at update {runner.update}/{config.n_updates}")
    return runner


def _fresh_runner(args: argparse.Namespace, log: Callable[[str], None]) -> Runner:
    preset = args.preset or "tuned"
    seed = 0 if args.seed is None else args.seed
    config = load_config(resolve_preset(preset))
    run_name = f"{Path(args.scenario).stem}_{Path(preset).stem}_s{seed}"
    out = Path(args.out) if args.out else package_root() / "results" / "runs" / run_name
    scenario = str(Path(args.scenario).resolve())
    runner = Runner(config, env_factory(scenario, config, args.backend), scenario=scenario, seed=seed,
                    out_dir=out, log=log)
    runner.start()
    log(f"train: {args.scenario} with preset {preset}, seed {seed}, {config.n_updates} updates of "
        f"{config.batch_size} steps -> {out}")
    return runner


def main(argv: Optional[List[str]] = None, log: Callable[[str], None] = print) -> int:
    args = build_parser().parse_args(argv)
    try:
        runner = _resumed_runner(args, log) if args.resume else _fresh_runner(args, log)
        summary = runner.run()
    except INPUT_ERRORS as error:
        print(f"train: {error}", file=sys.stderr)
        return 2
    except OSError as error:   # e.g. an output directory that cannot be written
        print(f"train: {error.filename or ''}: {error.strerror}", file=sys.stderr)
        return 2
    log(f"train: {summary.updates} updates, {summary.env_steps} steps, {summary.episodes} episodes in "
        f"{summary.wall_time:.1f} s; greedy makespan {summary.greedy_makespan:.2f} s; "
        f"actor {runner.actor_path}")
    return 0
