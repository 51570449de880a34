"""`generate_scenarios OUT_DIR`: write seeded random scenarios (XML + generated maps) to a directory.

    generate_scenarios /tmp/scenarios --count 20 --seed 0
    generate_scenarios /tmp/s --count 1 --robots 6 --tasks 16 --layout rooms --dag joins --stages 3
    generate_scenarios /tmp/s --count 20 --robots 3 --tasks 10 --layout ~/maps/my_floor.yaml

Each scenario draws its team size (2–16 robots), task count (4–32), layout, DAG kind, stages and
map size, except what the options fix. Each file goes through the scenario loader's
validation, its r_nav thresholds and episode timeout come from its nominal travel table
(model/generator.py). Bad input: one line on stderr, exit 2.
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import Optional, Sequence

from marl_mrta.common.config import ConfigError
from marl_mrta.env.settings import load_embedded_settings
from marl_mrta.model.generator import (DAG_KINDS, DEFAULT_MAX_LEG, LAYOUT_HELP, GeneratorError, ScenarioRequest,
                                       generate_scenarios)
from marl_mrta.model.scenario import ScenarioError


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="generate_scenarios", description=__doc__.split(":", 1)[1].split("\n")[0].strip())
    parser.add_argument("out_dir", type=Path, help="directory for the scenario files (maps under maps/)")
    parser.add_argument("--count", type=int, default=10, help="scenarios to write (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the whole set (default 0)")
    parser.add_argument("--robots", type=int, default=None, help="robots per scenario (2-16)")
    parser.add_argument("--tasks", type=int, default=None, help="tasks per scenario (4-32)")
    parser.add_argument("--layout", default=None, help=f"map: {LAYOUT_HELP}")
    parser.add_argument("--size", type=float, nargs=2, metavar=("WIDTH", "HEIGHT"), default=None,
                        help="interior of a generated map, m (default 10 x 6)")
    parser.add_argument("--dag", default=None, choices=DAG_KINDS, help="precedence shape")
    parser.add_argument("--stages", type=int, default=None, help="precedence depth (1: none)")
    parser.add_argument("--max-leg", type=float, default=None,
                        help=f"s: redraw poses until no nominal leg is longer (default {DEFAULT_MAX_LEG:g})")
    parser.add_argument("--name", default="gen", help="file name prefix (default gen)")
    parser.add_argument("--navigation", type=Path, default=None,
                        help="directory of the robots' navigation parameter files, written to each scenario's "
                             "<robots navigation> (default: the package's config/nav)")
    args = parser.parse_args(argv)
    fixed = {k: v for k, v in (("n_robots", args.robots), ("n_tasks", args.tasks), ("layout", args.layout),
                                ("dag", args.dag), ("stages", args.stages)) if v is not None}
    if args.size:
        fixed.update(width=args.size[0], height=args.size[1])
    try:
        if args.count < 1:
            raise GeneratorError(f"--count: must be at least 1, got {args.count}")
        model = load_embedded_settings().travel
        max_leg = args.max_leg if args.max_leg is not None else DEFAULT_MAX_LEG
        if args.navigation is not None and not args.navigation.is_dir():
            raise GeneratorError(f"--navigation: {args.navigation} is not a directory")
        navigation = str(args.navigation.resolve()) if args.navigation is not None else None
        base = replace(ScenarioRequest(), max_leg=max_leg, name=args.name, navigation=navigation, **fixed)
        scenarios = generate_scenarios(args.count, args.seed, args.out_dir, base, model, keep=tuple(fixed))
    except (GeneratorError, ScenarioError, ConfigError) as error:
        print(f"generate_scenarios: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"generate_scenarios: {args.out_dir}: cannot write ({error.strerror})", file=sys.stderr)
        return 2
    for scenario in scenarios:
        print(f"{scenario.source}: {scenario.n_robots} robots, {scenario.n_tasks} tasks, "
              f"timeout {scenario.episode_timeout:g} s")
    return 0
