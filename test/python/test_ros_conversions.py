"""StepOutput <-> marl_mrta/TaskEnvOutput: what the task manager's services carry arrives intact,
after a real serialisation (rospy gives uint8[] back as bytes), episode record included."""
import io

import numpy as np
import pytest

pytest.importorskip("marl_mrta.msg", reason="generated messages: source the catkin workspace (devel/setup.bash)")

from marl_mrta.env.factory import make_env  # noqa: E402
from marl_mrta.msg import TaskEnvOutput  # noqa: E402
from marl_mrta.ros.conversions import from_message, to_message  # noqa: E402
from marl_mrta.model.schedule import EpisodeRecord  # noqa: E402

from pathlib import Path  # noqa: E402

LAB_2R = Path(__file__).resolve().parents[2] / "scenarios" / "lab_2r.xml"


def over_the_wire(msg):
    buffer = io.BytesIO()
    msg.serialize(buffer)
    received = TaskEnvOutput()
    received.deserialize(buffer.getvalue())
    return received


def assert_same(a, b):
    np.testing.assert_array_equal(a.obs, b.obs)
    np.testing.assert_array_equal(a.state, b.state)
    np.testing.assert_array_equal(a.rewards, b.rewards)
    for name, values in a.reward_components.items():
        np.testing.assert_array_equal(values, b.reward_components[name])
    np.testing.assert_array_equal(a.action_mask, b.action_mask)
    assert a.done == b.done and a.truncated == b.truncated


def test_a_whole_episode_survives_serialisation():
    env = make_env(LAB_2R, mask="logic", seed=0)
    output = env.reset(seed=0)
    received = over_the_wire(to_message(output))
    assert isinstance(received.action_mask, bytes)
    back = from_message(received)
    assert_same(output, back)
    assert back.action_mask.dtype == bool and back.action_mask.shape == (env.n_agents, env.n_actions)
    # logic masks: B tasks (indices 4..7) are not allowed before their A task is finished.
    assert not back.action_mask[:, 4:8].any() and back.action_mask[:, :4].all()
    for actions in ([0, 2], [1, 3], [4, 6], [5, 7]):
        output = env.step(actions)
        back = from_message(over_the_wire(to_message(output)))
        assert_same(output, back)
        assert back.info == output.info            # typed fields, exact to the bit
    assert output.done
    record = back.info.episode
    assert isinstance(record, EpisodeRecord) and back.info.step == 4 and not back.info.abort_reason
    original = output.info.episode
    assert record.to_dict() == original.to_dict()
    assert record.logic_consistent and record.robot_task_lists() == original.robot_task_lists()


def test_a_mask_given_as_a_list_of_ints_is_read_too():
    env = make_env(LAB_2R, seed=0)
    msg = to_message(env.reset(seed=0))
    msg.action_mask = list(msg.action_mask)
    assert from_message(msg).action_mask.all()


def test_an_event_mode_episode_survives_serialisation():
    # Which robots decide, what the others are busy with, and the record's service starts and mode.
    from marl_mrta.baselines.random_policy import RandomPolicy
    env = make_env(LAB_2R, mask="none", seed=0, decision_mode="event")
    policy = RandomPolicy(env.n_agents, env.n_tasks, seed=3)
    output = env.reset(seed=0)
    policy.begin_episode(output)
    steps = 0
    while True:
        back = from_message(over_the_wire(to_message(output)))
        assert_same(output, back)
        assert back.info == output.info
        np.testing.assert_array_equal(back.deciding, output.deciding)
        if output.done or output.truncated:
            break
        output = env.step(policy.act(output))
        steps += 1
    assert steps > 1
    record, original = back.info.episode, output.info.episode
    assert record.decision_mode == "event" and record.to_dict() == original.to_dict()
    assert any(e.service_start is not None for e in record.entries)
    # Synchronous mode keeps its wire form: no deciding, no busy tasks.
    sync = from_message(over_the_wire(to_message(make_env(LAB_2R, seed=0).reset(seed=0))))
    assert sync.deciding is None and sync.info.robot_tasks == []
