"""The decision process on the shipped lab scenarios with the embedded executor: precedence
violations detected, duplicate and finished-task choices, the idle step, masks, timeout,
observation ranges, determinism."""
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.baselines.random_policy import RandomPolicy
from marl_mrta.env.factory import make_env
from marl_mrta.env.observation import float32_array
from marl_mrta.evaluation.loop import run_episodes

ROOT = Path(__file__).resolve().parents[2]
LAB_2R = ROOT / "scenarios" / "lab_2r.xml"


@pytest.fixture()
def env():
    return make_env(LAB_2R, seed=0)


def ids(env, *names):
    return [env.scenario.task_index(n) for n in names]


def test_precedence_violation_is_detected(env):
    env.reset(seed=0)
    b1, a3 = ids(env, "B1", "A3")
    out = env.step([b1, a3])
    assert out.info.correct_order == [False, True]
    assert env.task_correct[b1] is False and env.task_correct[a3] is True
    record = env.record
    entry = [e for e in record.entries if e.task == b1][0]
    assert entry.finished and not entry.logic_correct


def test_an_episode_with_a_violation_is_not_logic_consistent(env):
    env.reset(seed=0)
    a1, a2, a3, a4, b1, b2, b3, b4 = ids(env, "A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4")
    for joint in ([b1, a3], [a1, a4], [a2, b3], [b2, b4]):
        out = env.step(joint)
    assert out.done
    record = out.info.episode
    assert record.complete and not record.logic_consistent
    env.reset(seed=0)
    for joint in ([a1, a3], [a2, a4], [b1, b3], [b2, b4]):
        out = env.step(joint)
    assert out.done and out.info.episode.logic_consistent
    assert out.info.episode.robot_task_lists() == [[a1, a2, b1, b2], [a3, a4, b3, b4]]


def test_same_task_twice_in_a_step_finishes_once_and_wastes_the_later_trip(env):
    env.reset(seed=0)
    a1 = ids(env, "A1")[0]
    out = env.step([a1, a1])
    assert out.info.finished_task == [a1, None]      # robot 0 starts much closer
    assert env.n_finished == 1
    assert out.info.step_duration == pytest.approx(max(out.info.nav_time))
    assert out.info.idle_time[1] == pytest.approx(0.0)


def test_an_already_finished_task_is_driven_to_but_not_finished_again(env):
    env.reset(seed=0)
    a1, a3 = ids(env, "A1", "A3")
    env.step([a1, a3])
    out = env.step([env.n_tasks, a1])   # robot 1 drives across to A1, already done
    assert out.info.finished_task == [None, None]
    assert env.n_finished == 2 and env.finished_by[a1] == 0
    assert out.info.nav_time[1] > 5.0
    assert out.info.idle_time[0] == pytest.approx(out.info.step_duration)   # None robot waited


def test_all_none_lasts_the_minimum_step(env):
    env.reset(seed=0)
    out = env.step([env.n_tasks, env.n_tasks])
    assert out.info.step_duration == pytest.approx(env.settings.min_step)
    assert out.reward_components["idle"] == pytest.approx([-0.22 * env.settings.min_step] * 2)
    assert not out.done and not out.truncated


def test_masks_none_finished_logic():
    for mode in ("none", "finished", "logic"):
        env = make_env(LAB_2R, mask=mode, seed=0)
        first = env.reset(seed=0)
        a1, a3, b1 = ids(env, "A1", "A3", "B1")
        out = env.step([a1, a3])
        row = out.action_mask[0]
        assert out.action_mask.shape == (2, env.n_actions) and row[-1]   # None always allowed
        if mode == "none":
            assert first.action_mask.all() and row.all()
        elif mode == "finished":
            assert not row[a1] and not row[a3] and row[b1]
        else:
            assert not first.action_mask[0][b1]                # B1 waits for A1
            assert not row[a1] and row[b1] and not row[ids(env, "B2")[0]]


def test_timeout_truncates_and_records_an_incomplete_episode(env):
    env.reset(seed=0)
    b4 = ids(env, "B4")[0]
    out = None
    for _ in range(200):
        out = env.step([env.n_tasks, b4] if out is None or not env.finished[b4] else [env.n_tasks] * 2)
        if out.done or out.truncated:
            break
    assert out.truncated and not out.done
    record = out.info.episode
    assert record.makespan == pytest.approx(env.scenario.episode_timeout)
    assert not record.complete and not record.logic_consistent


def test_observation_and_state_shapes_and_ranges(env):
    out = env.reset(seed=0)
    assert out.obs.shape == (env.n_agents, env.obs_dim) and out.obs.dtype == np.float32
    assert out.state.shape == (env.state_dim,)
    outs = [out]
    policy = RandomPolicy(env.n_agents, env.n_tasks, seed=1)
    policy.begin_episode(out, 0)
    while not (out.done or out.truncated):
        out = env.step(policy.act(out))
        outs.append(out)
    for o in outs:
        assert o.obs.min() >= 0.0 and o.obs.max() <= 1.0
        assert o.state.min() >= 0.0 and o.state.max() <= 1.0
    # The robot-id one-hot differs between the robots' observations.
    assert not np.array_equal(outs[0].obs[0], outs[0].obs[1])


def test_same_seed_gives_the_same_episode_under_noise():
    def episode(seed):
        env = make_env(LAB_2R, profile="measured_tb3", seed=0)
        records = run_episodes(env, RandomPolicy(2, env.n_tasks, seed=5), 3, seed)
        return [(r.makespan, r.joint_actions, [(e.robot, e.task, e.end) for e in r.entries], r.collisions)
                for r in records]
    first = episode(11)
    assert first == episode(11)
    assert first != episode(12)


def test_noise_profile_changes_travel_times():
    nominal = make_env(LAB_2R, seed=0)
    noisy = make_env(LAB_2R, profile="measured_tb3", seed=0)
    a1 = ids(nominal, "A1")[0]
    nominal.reset(seed=3)
    noisy.reset(seed=3)
    t_nominal = nominal.step([a1, nominal.n_tasks]).info.nav_time[0]
    t_noisy = noisy.step([a1, noisy.n_tasks]).info.nav_time[0]
    assert t_nominal == pytest.approx(nominal.executor.table.nominal_time[0, 2 + a1])
    assert t_noisy > t_nominal   # slower robots and longer paths only


def test_service_time_extends_the_step_and_the_finish_time():
    env = make_env(ROOT / "test" / "data" / "scenarios" / "valid.xml", seed=0)   # B1: 1.5 s service
    env.reset(seed=0)
    a1, b1 = ids(env, "A1", "B1")
    none = env.n_tasks
    env.step([a1, none])
    start = env.elapsed
    out = env.step([b1, none])
    nav = out.info.nav_time[0]
    assert out.info.step_duration == pytest.approx(nav + 1.5)
    assert env.finish_time[b1] == pytest.approx(start + nav + 1.5)
    assert out.info.idle_time == pytest.approx([0.0, nav + 1.5])
    assert out.info.finish_order == [2, None]
    entry = out.info.episode.entries[-1]
    assert entry.reach == pytest.approx(start + nav) and entry.service_end == pytest.approx(start + nav + 1.5)


class AbortingExecutor:
    """Test double of an executor whose simulator is lost during the second step (the ROS
    executor's abort path); the embedded executor above is the real one."""

    def __init__(self, real):
        self.real = real
        self.n_robots = real.n_robots
        self.steps = 0

    def reset(self, seed=None):
        self.real.reset(seed)
        self.steps = 0

    def start_step(self, goals, time_limit):
        self.steps += 1
        outcome = self.real.start_step(goals, time_limit)
        if self.steps == 2:
            outcome.aborted, outcome.abort_reason = True, "simulator lost (no /clock for 2.0 s)"
            for robot in outcome.robots:
                robot.reached = False
        return outcome

    def finish_step(self, duration):
        self.real.finish_step(duration)

    def poses(self):
        return self.real.poses()


def test_an_aborted_step_ends_the_episode_with_its_reason():
    real = make_env(LAB_2R, seed=0).executor
    env = make_env(LAB_2R, executor=AbortingExecutor(real), seed=0)
    env.reset(seed=0)
    a1, a3 = ids(env, "A1", "A3")
    assert not env.step([a1, a3]).truncated
    out = env.step([a1, a3])
    assert out.truncated and not out.done
    assert out.info.abort_reason == "simulator lost (no /clock for 2.0 s)"
    assert out.info.episode.abort_reason == out.info.abort_reason
    with pytest.raises(RuntimeError):
        env.step([a1, a3])


def test_float32_array_rounds_as_numpy_does():
    values = [1 / 3, 2 / 3, 0.1, -0.0, 1e-40, 3.4e38, 1e39, -1e39, float("inf"), 1, True, 123.456]
    with np.errstate(over="ignore"):
        expected = np.array(values, dtype=np.float32)
        got = float32_array(values)
    assert got.dtype == np.float32 and got.tobytes() == expected.tobytes()


def test_every_output_owns_writable_arrays(env):
    first = env.reset(seed=1)
    second = env.step([env.n_tasks, env.n_tasks])
    for out in (first, second):
        arrays = [out.obs, out.state, out.rewards, out.action_mask, *out.reward_components.values()]
        assert all(a.flags.writeable for a in arrays)
    first.action_mask[:] = False
    first.obs[:] = -1.0
    third = env.step([env.n_tasks, env.n_tasks])
    assert third.action_mask.any() and (second.obs >= 0.0).all() and (third.state >= 0.0).all()
