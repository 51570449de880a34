"""The reference's solvers: the CP-SAT step model has the A*'s optimum (random small instances,
with and without a goal timeout, and the lab scenarios) and its plans replay to it through the
step rules and the embedded environment; the relaxations never exceed the optimum; solves are
reproducible; every solver stays within its budget and says so in one line; the reference
picks A* for small teams and CP-SAT otherwise."""
import dataclasses
import math
import random
from pathlib import Path

import pytest

from marl_mrta.baselines import cpsat
from marl_mrta.baselines.auction import solve_auction
from marl_mrta.baselines.cpsat import CpSatBudget
from marl_mrta.baselines.exact import AStarBudget, solve_exact
from marl_mrta.baselines.plan import simulate_joint_actions
from marl_mrta.baselines.reference import choose_solver, scheduling_instance, solve_reference
from marl_mrta.baselines.relaxation import solve_relaxation
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.baselines.step_model import solve_step_model
from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.evaluation.policies import PlanPolicy
from test_task_baselines import random_instance

ROOT = Path(__file__).resolve().parents[2]
BUDGET = CpSatBudget(time_limit=20.0)
SHAPES = [(2, 3), (3, 3), (2, 4), (3, 4), (4, 4), (2, 5), (3, 5)]


def small_instance(case: int):
    """Random instances; every third one with a goal timeout that forces legs over other goals."""
    rng = random.Random(9000 + case)
    inst = random_instance(rng, *SHAPES[case % len(SHAPES)], whole_seconds=case % 2 == 1)
    if case % 3 == 0:
        inst = dataclasses.replace(inst, goal_timeout=6.0 if case % 2 else 6.5)
    return inst


def assert_replays(inst, plan):
    run = simulate_joint_actions(inst, plan.joint_actions)
    assert run.complete and run.violations == 0
    assert run.elapsed == pytest.approx(plan.makespan, abs=1e-9)


@pytest.mark.parametrize("case", range(24))
def test_step_model_optimum_equals_astar_on_random_instances(case):
    inst = small_instance(case)
    optimum = solve_exact(inst)
    hint = solve_auction(inst)
    if not optimum.proven_optimal:            # no complete plan at all under this goal timeout
        assert not hint.complete
        return
    result = solve_step_model(inst, BUDGET, hint)
    assert result.proven_optimal and result.steps >= result.steps_needed
    assert result.plan.makespan == pytest.approx(optimum.makespan, abs=1e-5)
    assert result.lower_bound == result.plan.makespan
    assert_replays(inst, result.plan)


@pytest.mark.parametrize("case", range(12))
def test_step_model_equals_astar_under_a_precedence_margin(case):
    """With a margin, both solvers leave at least that much between a predecessor's finish and its
    successor's arrival in one step, agree on the optimum, and never beat the optimum without it."""
    plain = small_instance(case)
    inst = dataclasses.replace(plain, precedence_margin=1.5)
    optimum = solve_exact(inst)
    if not optimum.proven_optimal:
        return
    result = solve_step_model(inst, BUDGET, solve_auction(inst))
    assert result.proven_optimal
    assert result.plan.makespan == pytest.approx(optimum.makespan, abs=1e-5)
    assert_replays(inst, result.plan)
    for plan in (optimum, result.plan):
        assert simulate_joint_actions(inst, plan.joint_actions).thinnest_margin > 1.5
    assert optimum.makespan >= solve_exact(plain).makespan - 1e-9


def test_a_precedence_margin_changes_plans_that_were_too_thin():
    """Over the random instances, the margin moves some optima: the test above is not vacuous."""
    moved = 0
    for case in range(12):
        plain = small_instance(case)
        free = solve_exact(plain)
        if not free.proven_optimal:
            continue
        if simulate_joint_actions(plain, free.joint_actions).thinnest_margin <= 1.5:
            margin = solve_exact(dataclasses.replace(plain, precedence_margin=1.5))
            moved += margin.makespan > free.makespan + 1e-9
    assert moved >= 2


@pytest.fixture(scope="module", params=["lab_2r", "lab_3r", "lab_4r"])
def lab(request):
    env = make_env(ROOT / "scenarios" / f"{request.param}.xml", seed=0)
    return env, scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout)


def test_step_model_equals_astar_on_the_lab_and_replays_in_the_environment(lab):
    env, inst = lab
    optimum = solve_exact(inst)
    result = solve_step_model(inst, BUDGET, solve_auction(inst))
    assert optimum.proven_optimal and result.proven_optimal
    assert result.plan.makespan == pytest.approx(optimum.makespan, abs=1e-5)
    assert_replays(inst, result.plan)
    record = run_episodes(env, PlanPolicy(result.plan, env.n_agents, env.n_tasks), 1, 0)[0]
    assert record.complete and record.logic_consistent
    assert record.makespan == pytest.approx(result.plan.makespan, abs=1e-9)


@pytest.mark.parametrize("case", range(18))
def test_relaxations_never_exceed_the_optimum(case):
    inst = small_instance(case)
    optimum = solve_exact(inst).makespan
    hint = solve_auction(inst)
    loose = solve_relaxation(inst, BUDGET, "asynchronous", hint if hint.complete else None)
    tight = solve_relaxation(inst, BUDGET, "synchronous", hint if hint.complete else None)
    assert loose.outcome.optimal and tight.outcome.status in ("OPTIMAL", "INFEASIBLE")
    assert loose.lower_bound <= tight.lower_bound + 1e-9
    if math.isfinite(optimum):
        assert tight.lower_bound <= optimum + 1e-9
        assert sorted(t for route in tight.routes for t in route) == list(range(inst.n_tasks))


def varied_instance(case: int):
    """Random instances with goal timeouts that force legs over other goals (travel times are
    asymmetric and break the triangle inequality, so passing over a goal can be quicker) and
    long minimum steps."""
    rng = random.Random(50000 + case)
    shapes = SHAPES + [(2, 6), (3, 6)]
    inst = random_instance(rng, *shapes[case % len(shapes)], whole_seconds=case % 2 == 1)
    if case % 3 == 0:
        inst = dataclasses.replace(inst, goal_timeout=rng.choice([4.0, 5.0, 6.0, 6.5, 7.5]))
    if case % 4 == 1:
        inst = dataclasses.replace(inst, min_step=rng.choice([2.0, 3.5, 6.0]))
    return inst


def test_stepwise_relaxation_is_a_tight_lower_bound():
    """Never above the A* optimum (a bound that were not one fails here), and equal to it on
    most instances: the arrival exactly one leg after the step's start and the chains between
    whole steps make it tight (the synchronous one meets the optimum on a third of these)."""
    met = solved = 0
    for case in range(90):
        inst = varied_instance(case)
        optimum = solve_exact(inst)
        if not optimum.proven_optimal:
            continue
        hint = solve_auction(inst)
        relaxed = solve_relaxation(inst, BUDGET, "stepwise", hint if hint.complete else None,
                                   hint.makespan if hint.complete else None)
        assert relaxed.outcome.optimal
        assert relaxed.lower_bound <= optimum.makespan + 1e-9, case
        solved += 1
        met += relaxed.lower_bound >= optimum.makespan - 0.02
    assert solved >= 80 and met >= solved // 2


def test_stepwise_relaxation_meets_the_optimum_on_the_lab(lab):
    _, inst = lab
    optimum = solve_exact(inst).makespan
    relaxed = solve_relaxation(inst, BUDGET, "stepwise", solve_auction(inst))
    assert relaxed.outcome.optimal and optimum - 0.05 <= relaxed.lower_bound <= optimum + 1e-9


def test_a_solve_is_reproducible(monkeypatch):
    """Deterministic time and one worker: the same settings give the same plan (the wall-clock
    guard lifted so that a loaded machine cannot stop one of the two runs earlier)."""
    monkeypatch.setattr(cpsat, "WALL_FACTOR", 1000.0)
    inst = random_instance(random.Random(77), 5, 9)
    hint = solve_auction(inst)
    budget = CpSatBudget(time_limit=0.5, seed=3)
    first = solve_step_model(inst, budget, hint)
    second = solve_step_model(inst, budget, hint)
    assert first.plan.joint_actions == second.plan.joint_actions
    assert first.lower_bound == second.lower_bound
    relaxed = [solve_relaxation(inst, budget, "synchronous", hint).routes for _ in range(2)]
    assert relaxed[0] == relaxed[1]


def test_astar_refuses_a_batch_beyond_its_memory_budget():
    inst = random_instance(random.Random(5), 6, 16)
    plan = solve_exact(inst, budget=AStarBudget(memory_mb=2048))
    status = plan.details["status"]
    assert not plan.proven_optimal and plan.robot_tasks == [[] for _ in range(6)]
    assert "\n" not in status and status.startswith("A* refused: 2.41e+07 joint actions per state ((16+1)^6)")
    assert plan.details["lower_bound"] > 0


def test_astar_stops_at_its_state_budget_with_a_valid_lower_bound():
    inst = random_instance(random.Random(11), 3, 5)
    optimum = solve_exact(inst).makespan
    stopped = solve_exact(inst, budget=AStarBudget(max_states=40))
    assert not stopped.proven_optimal and stopped.details["status"].startswith("A* stopped at")
    assert 0 < stopped.details["lower_bound"] <= optimum + 1e-9


def test_step_model_is_not_built_beyond_its_memory_budget():
    inst = random_instance(random.Random(5), 4, 6)
    result = solve_step_model(inst, CpSatBudget(memory_mb=1.0), solve_auction(inst))
    assert result.plan is None and not result.proven_optimal
    assert result.status.startswith("step model not built:") and "\n" not in result.status


def test_reference_serves_the_lab_with_astar_proven(lab):
    _, inst = lab
    settings = load_baseline_settings()
    assert choose_solver(inst, settings) == "astar"
    reference = solve_reference(inst, settings)
    assert reference.proven_optimal and reference.gap == 0.0 and reference.plan.proven_optimal
    assert reference.best_source == "astar" and reference.lower_bound == reference.best_makespan


@pytest.mark.slow
def test_reference_serves_a_larger_team_with_cpsat():
    settings = load_baseline_settings().with_cpsat(time_limit=1.0)
    larger = random_instance(random.Random(3), 6, 14)
    assert choose_solver(larger, settings) == "cpsat"
    reference = solve_reference(larger, settings)
    assert reference.solver == "cpsat" and len(reference.log) in (3, 4, 5)  # stepwise after a solved synchronous, probes
    assert reference.lower_bound <= reference.best_makespan
    assert reference.gap == 0.0 or not reference.plan.proven_optimal
    assert_replays(larger, reference.plan)


def test_reference_falls_back_to_cpsat_when_astar_stops():
    inst = random_instance(random.Random(21), 3, 6)
    settings = dataclasses.replace(load_baseline_settings().with_cpsat(time_limit=1.0),
                                   astar=AStarBudget(max_states=30))
    reference = solve_reference(inst, settings)
    assert reference.log[0].startswith("A* stopped at") and len(reference.log) in (4, 5, 6)
    assert reference.lower_bound <= solve_exact(inst).makespan + 1e-9
    assert_replays(inst, reference.plan)


@pytest.mark.slow
def test_plans_send_one_robot_per_goal():
    """Two robots sent to one goal in a step: the second finds the first standing there. Under
    short goal timeouts robots reach far goals over other goals, where they would meet."""
    for case in range(24):
        inst = small_instance(case)
        for margin in (0.0, 1.5):
            inst = dataclasses.replace(inst, precedence_margin=margin)
            plans = [solve_exact(inst), solve_auction(inst)]
            if plans[0].proven_optimal:
                plans.append(solve_step_model(inst, BUDGET, plans[1]).plan)
            for plan in plans:
                for step in plan.joint_actions:
                    sent = [g for g in step if g is not None]
                    assert len(sent) == len(set(sent)), (case, margin, plan.details.get("solver"), step)
