"""The planners' view of a scenario and the reference every method is measured against.

`scheduling_instance` reduces a scenario to the nominal numbers the planners work on (the
travel-time table of the configured travel model); `exact_reference` proves the minimum
makespan on it. Training, evaluation, execution and the benchmarks all take the reference
from here.
"""
from __future__ import annotations

from typing import Optional, Tuple

from marl_mrta.baselines.auction import solve_auction
from marl_mrta.baselines.exact import solve_exact
from marl_mrta.baselines.plan import Plan, SchedulingInstance
from marl_mrta.baselines.settings import BaselineSettings, load_baseline_settings
from marl_mrta.env.factory import scenario_travel_table
from marl_mrta.model.scenario import Scenario


def scheduling_instance(scenario: Scenario, min_step: float) -> SchedulingInstance:
    """The scenario in nominal numbers: plans always come from the nominal travel times."""
    return SchedulingInstance.from_scenario(scenario, scenario_travel_table(scenario), min_step)


def exact_reference(instance: SchedulingInstance, settings: Optional[BaselineSettings] = None) -> Plan:
    """The proven optimum, with the auction's consistent plan as the search's first bound."""
    settings = settings or load_baseline_settings()
    auction = solve_auction(instance, settings.auction_objective)
    bound = auction.makespan if auction.logic_violations == 0 else None
    return solve_exact(instance, settings.exact_max_expansions, upper_bound=bound)


def scenario_reference(scenario: Scenario, min_step: float,
                       settings: Optional[BaselineSettings] = None) -> Tuple[Plan, SchedulingInstance]:
    """exact_reference of a scenario, with the instance it was solved on."""
    instance = scheduling_instance(scenario, min_step)
    return exact_reference(instance, settings), instance
