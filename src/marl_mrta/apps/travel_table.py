"""`travel_table SCENARIO`: a scenario's nominal travel-time table and the suggested r_nav thresholds."""
from __future__ import annotations

import argparse
import sys
from typing import Optional, Sequence

from marl_mrta.common.config import ConfigError
from marl_mrta.env.factory import scenario_travel_table
from marl_mrta.model.scenario import ScenarioError, load_scenario
from marl_mrta.model.travel import suggest_nav_thresholds


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="travel_table", description=__doc__.split(":", 1)[1].strip())
    parser.add_argument("scenario", help="scenario XML file")
    args = parser.parse_args(argv)
    try:
        scenario = load_scenario(args.scenario, nav_time_required=False)
        table = scenario_travel_table(scenario)
    except (ScenarioError, ConfigError) as error:
        print(f"travel_table: {error}", file=sys.stderr)
        return 2
    names = [r.id for r in scenario.robots] + [t.id for t in scenario.tasks]
    print("nominal travel time (s), row = from, column = to")
    print(" " * 6 + "".join(f"{n:>7}" for n in names))
    for a, name in enumerate(names):
        print(f"{name:>6}" + "".join(f"{table.nominal_time[a, b]:7.1f}" for b in range(len(names))))
    t_min, t_avg, t_max = suggest_nav_thresholds(table, scenario.n_robots)
    given = scenario.nav_thresholds
    print(f'suggested <nav_time t_min="{t_min}" t_avg="{t_avg}" t_max="{t_max}"/> '
          + (f'(scenario has {given.t_min:g} / {given.t_avg:g} / {given.t_max:g})' if given else "(scenario has none)"))
    return 0
