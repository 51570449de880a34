"""The reward of SPEC "Reward" on hand-made steps: the four r_logic cases, r_nav inside the
range and at/after t_max, r_idle, r_col, the weighted sum, config overrides; and the same
values coming out of the environment's step()."""
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.env.factory import make_env
from marl_mrta.common.config import ConfigError
from marl_mrta.model.reward import NavThresholds, RewardConfig, nav_reward, step_rewards
from marl_mrta.model.rules import resolve_step

ROOT = Path(__file__).resolve().parents[2]
THRESHOLDS = NavThresholds(t_min=4.0, t_avg=20.0, t_max=50.0)
# Two tasks, A (0) before B (1), no service time.
PREDECESSORS = [[], [0]]
SERVICE = [0.0, 0.0]


@pytest.fixture(scope="module")
def config():
    return RewardConfig.load(THRESHOLDS)


def rewards_of(config, goals, nav, reached, finished_before=(False, False), collisions=None):
    collisions = collisions or [0] * len(goals)
    step = resolve_step(goals, nav, reached, collisions, list(finished_before), PREDECESSORS, SERVICE,
                        time_limit=1000.0, min_step=1.0)
    return step, step_rewards(config, [g is not None for g in goals], step.correct_order, step.robot_finished,
                              step.nav_time, step.collisions, step.idle_time)


def test_shipped_defaults_are_the_spec_values(config):
    assert (config.w_logic, config.w_time, config.w_idle, config.w_col) == (0.6, 0.35, 0.2, 0.8)
    assert (config.logic_correct_finished, config.logic_correct_unfinished,
            config.logic_wrong_finished, config.logic_wrong_unfinished) == (5.0, 0.0, -2.0, -5.0)
    assert (config.col_per_event, config.idle_per_second, config.nav_at_or_over_max) == (-0.5, -0.22, -8.0)


def test_logic_correct_order_and_finished_is_plus_5(config):
    _, out = rewards_of(config, [0], [10.0], [True])
    assert out.logic == [5.0]


def test_logic_correct_order_not_finished_is_0(config):
    # Both robots head for A; robot 1 arrives later and finishes nothing.
    step, out = rewards_of(config, [0, 0], [10.0, 12.0], [True, True])
    assert step.robot_finished == [True, False]
    assert out.logic == [5.0, 0.0]


def test_logic_wrong_order_but_finished_is_minus_2(config):
    _, out = rewards_of(config, [1], [10.0], [True])   # B before A
    assert out.logic == [-2.0]


def test_logic_wrong_order_not_finished_is_minus_5(config):
    _, out = rewards_of(config, [1], [10.0], [False])  # B before A, and the robot failed
    assert out.logic == [-5.0]


def test_logic_same_step_order_counts_by_arrival_time(config):
    # A arrives at 8 s, B at 12 s in the same step: correct. B first: wrong.
    _, out = rewards_of(config, [0, 1], [8.0, 12.0], [True, True])
    assert out.logic == [5.0, 5.0]
    _, out = rewards_of(config, [0, 1], [12.0, 8.0], [True, True])
    assert out.logic == [5.0, -2.0]
    _, out = rewards_of(config, [0, 1], [8.0, 8.0], [True, True])   # a tie is not "strictly before"
    assert out.logic == [5.0, -2.0]


def test_nav_inside_range_follows_the_formula(config):
    assert nav_reward(config, True, 10.0) == pytest.approx(2.0 - 2.0 * (10.0 - 4.0) / 20.0)
    assert nav_reward(config, True, 49.9) == pytest.approx(2.0 - 2.0 * (49.9 - 4.0) / 20.0)



def test_nav_at_or_below_t_min_is_the_configured_value(config):
    # SPEC defines no value there; only a trip to the robot's own place is that short.
    assert config.nav_at_or_below_min == 0.0
    assert nav_reward(config, True, 4.0) == 0.0 and nav_reward(config, True, 0.1) == 0.0
    assert nav_reward(config, False, 10.0) == 0.0   # None: nothing navigated


def test_nav_at_or_over_t_max_is_minus_8(config):
    assert nav_reward(config, True, 50.0) == -8.0
    assert nav_reward(config, True, 75.0) == -8.0


def test_idle_is_proportional_to_waiting_time(config):
    # Robot 0 drives 10 s, robot 1 drives 4 s and waits 6 s; a None robot waits the whole step.
    step, out = rewards_of(config, [0, 0, None], [4.0, 10.0, 0.0], [True, True, False])
    assert step.duration == pytest.approx(10.0)
    assert out.idle == pytest.approx([-0.22 * 6.0, 0.0, -0.22 * 10.0])
    assert out.nav[2] == 0.0 and out.logic[2] == 0.0


def test_collision_is_a_fixed_value_per_event(config):
    _, out = rewards_of(config, [0, None], [10.0, 0.0], [True, False], collisions=[2, 1])
    assert out.collision == pytest.approx([-1.0, -0.5])


def test_total_is_the_weighted_sum(config):
    _, out = rewards_of(config, [1, 0], [12.0, 30.0], [True, True], collisions=[1, 0])
    for i in range(2):
        expected = 0.6 * out.logic[i] + 0.35 * out.nav[i] + 0.8 * out.collision[i] + 0.2 * out.idle[i]
        assert out.total[i] == pytest.approx(expected)
    assert out.logic == [-2.0, 5.0]


def test_overrides_change_values_and_unknown_keys_fail():
    changed = RewardConfig.load(THRESHOLDS, overrides={"logic": {"wrong_finished": 0.0}, "weights": {"logic": 1.0}})
    assert changed.logic_wrong_finished == 0.0 and changed.w_logic == 1.0
    with pytest.raises(ConfigError, match="logic.typo: unknown key"):
        RewardConfig.load(THRESHOLDS, overrides={"logic": {"typo": 1.0}})


def test_environment_step_reports_the_same_components():
    env = make_env(ROOT / "scenarios" / "lab_2r.xml", seed=0)
    env.reset(seed=0)
    b1, a3 = env.scenario.task_index("B1"), env.scenario.task_index("A3")
    out = env.step([b1, a3])   # robot 0 goes to B1 before A1 is done: wrong order, finished
    reward = env.reward
    nav = out.info.nav_time
    assert out.reward_components["logic"].tolist() == [-2.0, 5.0]
    assert out.reward_components["nav"] == pytest.approx([nav_reward(reward, True, t) for t in nav])
    idle = out.info.idle_time
    assert idle[0] == pytest.approx(0.0) and idle[1] == pytest.approx(nav[0] - nav[1])
    assert out.reward_components["idle"] == pytest.approx([-0.22 * t for t in idle])
    expected = [0.6 * out.reward_components["logic"][i] + 0.35 * out.reward_components["nav"][i]
                + 0.2 * out.reward_components["idle"][i] for i in range(2)]
    assert out.rewards == pytest.approx(np.array(expected, dtype=np.float32))
