"""Event mode (env/event_env.py, model/event_rules.py, baselines/plan.py): a robot that comes
free decides at once while the others drive on, robots early at a successor wait for its
predecessors, the planners' schedule of routes is the environment's own, and its reference is
never longer than the synchronous one's."""
import math
import random
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.baselines.plan import decode_routes
from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.random_policy import RandomPolicy
from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.common.config import ConfigError
from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.policies import EventPlanPolicy
from marl_mrta.baselines.plan import Plan
from marl_mrta.model.reward import RewardConfig

ROOT = Path(__file__).resolve().parents[2]
LABS = [ROOT / "scenarios" / f"{name}.xml" for name in ("lab_2r", "lab_3r", "lab_4r")]
CHAINS = ROOT / "test" / "data" / "scenarios" / "chains_3r6t.xml"


def event_env(scenario, **kwargs):
    return make_env(scenario, decision_mode="event", mask=kwargs.pop("mask", "finished"), seed=0, **kwargs)


def random_routes(rng, n_robots, n_tasks):
    order = list(range(n_tasks))
    rng.shuffle(order)
    routes = [[] for _ in range(n_robots)]
    for task in order:
        routes[rng.randrange(n_robots)].append(task)
    return routes


@pytest.mark.parametrize("scenario", LABS + [CHAINS], ids=lambda p: p.stem)
def test_the_planners_schedule_of_routes_is_the_environments(scenario):
    env = event_env(scenario)
    instance = scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout, decision_mode="event")
    rng = random.Random(scenario.stem)
    compared = 0
    for _ in range(30):
        routes = random_routes(rng, env.n_agents, env.n_tasks)
        planned = decode_routes(instance, routes)
        plan = Plan("routes", routes, [], planned.elapsed, 0, instance=instance)
        record = run_episode(env, EventPlanPolicy(plan, env.n_agents, env.n_tasks), seed=0)
        if planned.complete and planned.elapsed < env.scenario.episode_timeout:
            compared += 1
            assert record.complete and record.logic_consistent
            assert record.makespan == pytest.approx(planned.elapsed, abs=1e-6)
            for task, finish in enumerate(planned.finish):
                assert record.finish_time[task] == pytest.approx(finish, abs=1e-6)
        elif not planned.complete:   # routes that wait on each other in a cycle never finish: nor does the episode
            assert not record.complete
    assert compared >= 5


@pytest.mark.parametrize("scenario", LABS + [CHAINS], ids=lambda p: p.stem)
def test_no_task_is_ever_done_out_of_order_and_robots_wait_at_successors(scenario):
    env = event_env(scenario, mask="none")
    held = 0.0
    for seed in range(20):
        policy = RandomPolicy(env.n_agents, env.n_tasks, seed=seed)
        record = run_episode(env, policy, seed=seed, episode=seed)
        for task, preds in enumerate(env.scenario.predecessors):
            if record.finish_time[task] is not None:
                starts = [e.service_start for e in record.entries if e.task == task and e.finished]
                assert all(record.finish_time[p] is not None and record.finish_time[p] <= starts[0] + 1e-9
                           for p in preds)
        held += sum(max(0.0, (e.service_start or 0.0) - (e.reach or 0.0)) for e in record.entries if e.finished)
    if any(env.scenario.predecessors):
        assert held > 0.0   # random robots reach successors early, and wait there


def test_a_robot_that_finishes_decides_at_once_while_the_others_drive_on():
    env = event_env(LABS[0])
    out = env.reset(seed=0)
    assert out.deciding.all()                         # everyone decides at the start
    out = env.step([0, 7])                            # tb3_0 -> A1 (near), tb3_1 -> B4 (far)
    assert list(np.flatnonzero(out.deciding)) == [0]  # A1 done: tb3_0 decides, tb3_1 still drives
    assert out.info.robot_tasks[1] == 7 and out.info.finished[0]
    assert out.action_mask[1].tolist() == [False] * env.n_tasks + [True]   # not deciding: None alone
    ignored = env.step([1, 0])                        # tb3_1's action is not its to take now
    assert ignored.info.robot_tasks[1] == 7 or ignored.info.finished[7]


def test_rewards_per_robot_add_up_to_its_record():
    env = event_env(LABS[1])
    reward = RewardConfig.load(env.scenario.nav_thresholds, None, env.scenario.reward_overrides)
    out = env.reset(seed=3)
    policy = RandomPolicy(env.n_agents, env.n_tasks, seed=3)
    policy.begin_episode(out, 0)
    idle = np.zeros(env.n_agents)
    while not (out.done or out.truncated):
        out = env.step(policy.act(out))
        idle += out.reward_components["idle"]
    record = out.info.episode
    # r_idle accrues per second waited, whatever the transitions: the record's waits, scaled.
    assert np.allclose(idle, np.asarray(record.idle_time) * reward.idle_per_second, atol=1e-3)


def test_the_event_reference_is_proven_and_never_longer_than_the_synchronous_one():
    for scenario in LABS + [CHAINS]:
        env = event_env(scenario)
        sync = scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout)
        event = scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout,
                                    decision_mode="event")
        synchronous, evented = solve_reference(sync), solve_reference(event)
        assert evented.lower_bound <= evented.best_makespan + 1e-9
        assert evented.best_makespan <= synchronous.best_makespan + 1e-6
        assert evented.proven_optimal
        ga = solve_ga(event)
        assert ga.makespan >= evented.lower_bound - 1e-6
        # The reference's plan, run as events, takes what it was planned to take.
        record = run_episode(env, EventPlanPolicy(evented.plan, env.n_agents, env.n_tasks), seed=0)
        assert record.makespan == pytest.approx(evented.best_makespan, abs=1e-6)
        assert record.idle_share([t.service_time for t in env.scenario.tasks]) <= 1.0


def test_an_unknown_decision_mode_is_one_line():
    with pytest.raises(ConfigError, match="decision_mode: 'evnt' is not one of synchronous, event"):
        make_env(LABS[0], decision_mode="evnt")
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "evaluate"), "--method", "exact",
                           "--decision-mode", "evnt"], capture_output=True, text=True)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == ["evaluate: --decision-mode: 'evnt' is not one of synchronous, event"]


def test_synchronous_episodes_know_no_deciding_flags():
    out = make_env(LABS[0], seed=0).reset(seed=0)
    assert out.deciding is None and not math.isnan(out.rewards.sum())
