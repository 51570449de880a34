"""Probing (baselines/probing.py): a makespan cap on a relaxation is infeasible exactly below its
optimum, the probed bound is never above the A* optimum and meets it on most random instances,
and the reference's bound rises with it where the relaxations alone leave a gap."""
import dataclasses
import random

import pytest

from marl_mrta.baselines import cpsat, reference as reference_module
from marl_mrta.baselines.auction import solve_auction
from marl_mrta.baselines.cpsat import BOUND_TIME, CpSatBudget
from marl_mrta.baselines.exact import solve_exact
from marl_mrta.baselines.probing import ProbeResult, probe_lower_bound
from marl_mrta.baselines.reference import solve_reference
from marl_mrta.baselines.relaxation import solve_relaxation
from marl_mrta.baselines.settings import load_baseline_settings
from test_task_baselines import random_instance
from test_task_cpsat import varied_instance

BUDGET = CpSatBudget(time_limit=20.0)


@pytest.mark.parametrize("kind", ["synchronous", "stepwise"])
def test_a_cap_is_infeasible_exactly_below_the_relaxations_optimum(kind):
    inst = varied_instance(4)
    solved = solve_relaxation(inst, BUDGET, kind)
    assert solved.outcome.optimal
    optimum = BOUND_TIME.ticks(solved.optimum)
    below = solve_relaxation(inst, BUDGET, kind, makespan_cap=BOUND_TIME.seconds(optimum - 0.5))
    assert below.outcome.status == "INFEASIBLE" and below.routes is None
    assert below.lower_bound == pytest.approx(solved.optimum)
    at = solve_relaxation(inst, BUDGET, kind, makespan_cap=BOUND_TIME.seconds(optimum + 0.5))
    assert at.routes is not None and at.lower_bound == 0.0
    assert at.optimum == pytest.approx(solved.optimum)
    assert "\n" not in below.status + at.status and "infeasible" in below.status


@pytest.mark.slow
def test_probed_bound_is_never_above_the_optimum_and_mostly_meets_it():
    """From the asynchronous bound up to the auction's makespan: never above the A* optimum (a
    cap proven infeasible that a plan meets fails here), and at the optimum on most instances
    (probing that raised nothing fails here)."""
    raised = met = probed = 0
    for case in range(30):
        inst = varied_instance(case)
        optimum = solve_exact(inst)
        auction = solve_auction(inst)
        if not optimum.proven_optimal or not auction.complete:
            continue
        start = solve_relaxation(inst, BUDGET, "asynchronous").lower_bound
        result = probe_lower_bound(inst, BUDGET, "stepwise", start, auction.makespan)
        assert start <= result.lower_bound <= optimum.makespan + 1e-9, case
        assert result.deterministic_seconds <= BUDGET.time_limit + 0.01 and "\n" not in result.status
        probed += 1
        raised += result.lower_bound > start + 1e-9
        met += result.lower_bound >= optimum.makespan - 0.02
    assert probed >= 25 and raised >= 20 and met >= 20


def test_probes_share_one_budget(monkeypatch):
    """Caps CP-SAT cannot decide each take a share of the budget, and all of them the budget
    (CP-SAT stops a hair past a deterministic limit). The wall-clock guard is lifted: on a loaded
    machine it cut a share short, and a fifth cap fitted in what was left."""
    monkeypatch.setattr(cpsat, "WALL_FACTOR", 1000.0)
    inst = random_instance(random.Random(3), 6, 14)
    start = solve_relaxation(inst, CpSatBudget(time_limit=0.5), "asynchronous").lower_bound
    result = probe_lower_bound(inst, CpSatBudget(time_limit=0.5), "stepwise", start, 10 * start)
    assert result.probes == 4 and 0.45 <= result.deterministic_seconds <= 0.5 + 0.01
    assert start <= result.lower_bound and result.status.count("?") == 4


def test_reference_bound_rises_with_probing_and_stays_below_the_optimum(monkeypatch):
    """The reference's CP-SAT path (A* not chosen) with a limit under which the synchronous
    relaxation is not solved: the probes raise its bound over the one without them (the same
    solves otherwise: one worker, deterministic time, the wall-clock guard lifted), and not above
    the A* optimum."""
    monkeypatch.setattr(cpsat, "WALL_FACTOR", 1000.0)
    inst = random_instance(random.Random(702), 3, 7)
    settings = dataclasses.replace(load_baseline_settings().with_cpsat(time_limit=0.2, workers=1), astar_max_batch=0)
    probed = solve_reference(inst, settings)
    monkeypatch.setattr(reference_module, "probe_lower_bound",
                        lambda instance, budget, kind, lower, upper: ProbeResult(kind, lower, status="no probes"))
    unprobed = solve_reference(inst, settings)
    assert probed.solver == "cpsat" and probed.log[-1].startswith("stepwise relaxation probed")
    assert unprobed.log[-1] == "no probes" and probed.bound_source == "stepwise relaxation probed"
    assert probed.lower_bound > unprobed.lower_bound + 1.0
    assert probed.lower_bound <= solve_exact(inst).makespan + 1e-9
