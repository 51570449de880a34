"""Planners under hold_successors (SchedulingInstance.hold_successors, set from the episodes' rules):
a plan may send a robot to a task whose predecessors finish later in the step (it waits there)
or in a later step (it stands there unserved), which the paper's rules count out of order. The
A*'s batched rules follow model/rules.py's hold, its optimum is the brute force's, and plans get
shorter where a robot would otherwise wait for the next step."""
import dataclasses
import json
import random
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.baselines.auction import solve_auction
from marl_mrta.baselines.exact import BatchedRules, solve_exact
from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.plan import SchedulingInstance, simulate_joint_actions
from marl_mrta.baselines.reference import solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from test_task_baselines import brute_force_makespan, random_instance, scalar_step

ROOT = Path(__file__).resolve().parents[2]


def held(inst: SchedulingInstance) -> SchedulingInstance:
    return dataclasses.replace(inst, hold_successors=True)


def lab_optimum(scenario: str, hold: bool):
    """The proven optimum of a lab scenario under the paper's rules or the hold, as evaluate plans it."""
    from marl_mrta.baselines.reference import scheduling_instance
    from marl_mrta.env.factory import make_env
    env = make_env(ROOT / "scenarios" / f"{scenario}.xml")
    plan = solve_exact(scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout,
                                           hold_successors=hold))
    assert plan.proven_optimal
    return plan.makespan


def test_the_batched_rules_under_the_hold_equal_the_scalar_rules():
    rng = random.Random(11)
    for trial in range(20):
        inst = held(random_instance(rng, rng.choice((2, 3)), rng.choice((3, 4)), whole_seconds=trial % 2 == 1))
        rules = BatchedRules(inst)
        done = np.array([rng.random() < 0.3 for _ in range(inst.n_tasks)])
        # robots on their starts or on any goal, open ones included (sent ahead, unserved)
        pos = np.array([rng.choice([r] + [inst.n_robots + j for j in range(inst.n_tasks)]) for r in range(inst.n_robots)])
        valid, duration, new_done, new_pos = rules.evaluate(done, pos)
        assert valid.all()
        for b, action in enumerate(rules.actions):
            goals = [int(a) if a < inst.n_tasks else None for a in action]
            step = scalar_step(inst, done.tolist(), pos.tolist(), goals)
            assert duration[b] == pytest.approx(step.duration)
            expected_done = done.copy()
            expected_done[[f.task for f in step.finished]] = True
            assert new_done[b].tolist() == expected_done.tolist()
            assert new_pos[b].tolist() == [p if g is None else inst.n_robots + g for p, g in zip(pos.tolist(), goals)]


@pytest.mark.parametrize("case", range(12))
def test_the_exact_plan_under_the_hold_is_the_brute_force_optimum_and_never_longer(case):
    rng = random.Random(2000 + case)
    n_robots, n_tasks = [(2, 2), (2, 3), (3, 2), (2, 4)][case % 4]
    paper = random_instance(rng, n_robots, n_tasks, whole_seconds=case % 2 == 1)
    plan = solve_exact(held(paper))
    assert plan.proven_optimal and plan.logic_violations == 0
    assert plan.makespan == pytest.approx(brute_force_makespan(held(paper)), abs=1e-9)
    assert plan.makespan <= solve_exact(paper).makespan + 1e-9
    run = simulate_joint_actions(held(paper), plan.joint_actions)
    assert run.complete and run.elapsed == pytest.approx(plan.makespan)


def chain_instance() -> SchedulingInstance:
    """Robot 0 next to A (service 4 s), robot 1 far from both; B after A, 6 s from robot 1.
    Paper's rules: robot 1 must arrive after A's finish (4.1 s), so it goes in the step after A's
    or on a leg longer than 4.1 s: 6 + 1 (B's service). Held, robot 1 goes with A's step and waits."""
    #               r0    r1    A     B
    travel = np.array([[0.1, 9.0, 0.1, 9.0],
                       [9.0, 0.1, 9.0, 3.0],
                       [0.1, 9.0, 0.1, 9.0],
                       [9.0, 3.0, 9.0, 0.1]])
    return SchedulingInstance(2, 2, travel, (4.0, 1.0), ((), (0,)), 1.0, task_ids=("A", "B"))


def test_a_robot_sent_ahead_waits_for_its_predecessor_instead_of_a_step():
    paper, hold = solve_exact(chain_instance()), solve_exact(held(chain_instance()))
    # Paper: A in step 1 (4.1 s; robot 1 cannot reach B after A's finish within it), B in step 2 (3 + 1 s).
    assert paper.makespan == pytest.approx(4.1 + 4.0)
    # Held: both in one step, robot 1 at B at 3 s, served from A's finish (4.1 s) to 5.1 s.
    assert hold.makespan == pytest.approx(5.1) and hold.joint_actions == [[0, 1]]
    for plan in (solve_ga(held(chain_instance()), load_baseline_settings().ga, seed=0),
                 solve_auction(held(chain_instance()))):
        assert plan.logic_violations == 0 and plan.makespan == pytest.approx(5.1)


def test_the_reference_keeps_only_bounds_that_hold_under_the_hold():
    """The CP-SAT step models bound the paper's rules (8.1 s here); under the hold only the
    asynchronous relaxation's bound is kept, and the hold's plan is the best known."""
    settings = dataclasses.replace(load_baseline_settings().with_cpsat(2.0, 1), astar_max_tasks=1)
    reference = solve_reference(held(chain_instance()), settings)
    assert reference.solver == "cpsat" and reference.bound_source in ("root bound", "asynchronous relaxation")
    assert reference.lower_bound <= 5.1 + 1e-9
    assert reference.plan.makespan == pytest.approx(5.1) and reference.plan.logic_violations == 0
    paper = solve_reference(chain_instance(), settings)
    assert paper.plan.makespan == pytest.approx(8.1) and paper.lower_bound > 5.1


@pytest.mark.slow
def test_a_heuristic_under_the_hold_keeps_its_plan_of_the_paper_rules_when_that_is_shorter():
    """Seed 0 of the GA finds a shorter plan on lab_3r under the paper's rules than under the hold;
    that one is kept, for the hold."""
    from marl_mrta.baselines.plan import under_either_rules
    from marl_mrta.baselines.reference import scheduling_instance
    from marl_mrta.env.factory import make_env
    env = make_env(ROOT / "scenarios" / "lab_3r.xml")
    instance = scheduling_instance(env.scenario, env.settings.min_step, hold_successors=True)
    ga = load_baseline_settings().ga
    alone = solve_ga(instance, ga, seed=0)
    paper = solve_ga(dataclasses.replace(instance, hold_successors=False), ga, seed=0)
    either = under_either_rules(lambda inst: solve_ga(inst, ga, seed=0), instance)
    assert paper.makespan < alone.makespan - 1e-6          # the case the test is about
    assert either.makespan == paper.makespan and either.joint_actions == paper.joint_actions
    assert either.instance is instance and either.logic_violations == 0


@pytest.mark.parametrize("scenario, hold_shortens", [("lab_2r", False), ("lab_3r", True)], ids=["lab_2r", "lab_3r"])
@pytest.mark.slow
def test_evaluate_plans_for_the_hold_it_runs_under(tmp_path, scenario, hold_shortens):
    """lab_3r's optimum is shorter when a robot may wait at a successor (lab_2r's is not); every
    episode keeps the order and ends at the proven optimum of the rules it runs under (ideal noise)."""
    from marl_mrta.apps.evaluate import main as evaluate_main
    makespans = {}
    for hold in (False, True):
        out = tmp_path / f"{scenario}_{hold}.json"
        args = ["--method", "exact,ga", "--scenario", str(ROOT / "scenarios" / f"{scenario}.xml"),
                "--episodes", "2", "--seed", "0", "--quiet", "--out", str(out)]
        assert evaluate_main(args + (["--hold-successors"] if hold else [])) == 0
        document = json.loads(out.read_text())
        for result in document["results"]:
            assert result["summary"]["logic_consistent_pct"] == 100.0
        makespans[hold] = document["results"][0]["summary"]["makespan_mean"]
        assert document["results"][0]["plan"]["makespan"] == pytest.approx(makespans[hold])
    for hold in (False, True):
        assert makespans[hold] == pytest.approx(lab_optimum(scenario, hold), abs=1e-6)
    if hold_shortens:
        assert makespans[True] < makespans[False] - 1e-6
    else:
        assert makespans[True] == pytest.approx(makespans[False], abs=1e-6)


@pytest.mark.parametrize("case", range(6))
def test_the_bound_kept_under_the_hold_is_below_the_holds_optimum(case):
    rng = random.Random(3000 + case)
    inst = held(random_instance(rng, *[(2, 3), (3, 3), (2, 4)][case % 3], whole_seconds=case % 2 == 1))
    settings = dataclasses.replace(load_baseline_settings().with_cpsat(2.0, 1), astar_max_tasks=1)
    reference = solve_reference(inst, settings)
    optimum = solve_exact(inst).makespan
    assert reference.lower_bound <= optimum + 1e-6 <= reference.plan.makespan + 2e-6


@pytest.mark.slow
def test_mappo_trains_under_the_hold_and_its_actor_sends_a_robot_ahead(tmp_path):
    """`--set hold_successors=true`: the run's environments hold, and the teacher plans for it
    (here the reference: lab_3r's optimum under the hold, in which R2 waits at B2, shorter than
    any plan of the paper's rules). Without the hold the same schedule would finish B2 before A2;
    the kept actor runs it in order under evaluate --hold-successors."""
    from marl_mrta.apps.evaluate import main as evaluate_main
    from marl_mrta.apps.train import main as train_main
    from marl_mrta.mappo.runner import Runner
    held_optimum = lab_optimum("lab_3r", hold=True)
    assert held_optimum < lab_optimum("lab_3r", hold=False) - 1e-6   # reached only by sending a robot ahead
    run = tmp_path / "run"
    assert train_main(["--scenario", str(ROOT / "scenarios" / "lab_3r.xml"), "--seed", "0", "--set",
                       "total_env_steps=1200", "--set", "teacher=reference", "--set", "hold_successors=true",
                       "--out", str(run)]) == 0
    offered = Runner.read_checkpoint(run / "checkpoint.pt")["self_imitation"]   # the teacher's plan for the hold
    assert offered["source"] == "the reference teacher's schedule"
    assert offered["makespan"] == pytest.approx(held_optimum, abs=1e-6)
    out = tmp_path / "policy.json"
    for flag in (["--hold-successors"], []):   # without the flag, from the actor file
        assert evaluate_main(["--method", "policy", "--policy", str(run / "actor.pt"), "--scenario",
                              str(ROOT / "scenarios" / "lab_3r.xml"), "--episodes", "1", "--quiet", *flag,
                              "--out", str(out)]) == 0
        document = json.loads(out.read_text())
        summary = document["results"][0]["summary"]
        assert document["hold_successors"] is True
        assert summary["makespan_mean"] == pytest.approx(held_optimum, abs=1e-6)
        assert summary["logic_consistent_pct"] == 100.0


def test_the_ros_backend_refuses_managers_whose_hold_differs_from_the_settings():
    """A run trained for the hold on managers without it (or the other way) would learn other rules."""
    from types import SimpleNamespace
    pytest.importorskip("rospy")
    from marl_mrta.mappo.config import MappoConfig
    from marl_mrta.mappo.runner import RunError
    from marl_mrta.ros.arena_pool import check_manager
    scenario = (ROOT / "scenarios" / "lab_2r.xml").resolve()
    manager = SimpleNamespace(manager="/arena_0/rl_task_allocation_manager", scenario_path=scenario,
                              settings=SimpleNamespace(mask="logic", hold_successors=False))
    check_manager(manager, manager, MappoConfig(action_mask="logic"), str(scenario))
    with pytest.raises(RunError, match="hold_successors: the manager's is False, the settings train with True"):
        check_manager(manager, manager, MappoConfig(action_mask="logic", hold_successors=True), str(scenario))
