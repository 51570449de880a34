"""Decentralised execution cores (no roscore): per-robot actors, the choice board, and the
orchestrating policy run through the evaluation runner on the embedded environment."""
import threading

import numpy as np
import pytest
import torch

from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.mappo.networks import Actor
from marl_mrta.mappo.policy import ActorPolicy
from marl_mrta.evaluation.decentralised import ActorTimeout, ChoiceBoard, DecentralisedPolicy
from marl_mrta.evaluation.robot_actor import ObservationError, RobotActor
from marl_mrta.common.paths import package_root

SCENARIO = package_root() / "scenarios" / "lab_2r.xml"


def make_env_logic():
    return make_env(SCENARIO, "embedded", mask="logic", seed=0)


def make_policy(env, seed=3):
    torch.manual_seed(seed)
    actor = Actor(env.obs_dim + env.n_agents, env.n_actions, 32)
    return ActorPolicy(actor, obs_dim=env.obs_dim, n_agents=env.n_agents, append_agent_id=True,
                       settings={"action_mask": "logic"}, source="test")


class CentralPolicy:
    """The reference: one ActorPolicy acting for all robots at once (evaluation's LearnedPolicy)."""

    def __init__(self, policy):
        self.policy = policy

    def begin_episode(self, first, episode=None):
        self.hidden = self.policy.initial_hidden(self.policy.n_agents)

    def act(self, output):
        actions, self.hidden = self.policy.act(output.obs, output.action_mask, self.hidden)
        return [int(a) for a in actions]


def in_process_actors(policy, board, n_agents):
    """Each robot's RobotActor answering on the board as its node would (synchronously)."""
    actors = [RobotActor(policy, i) for i in range(n_agents)]

    def send(i, row):
        decision = actors[i].decide(row.episode, row.step, row.episode_start, row.obs,
                                    row.action_mask.tobytes(), row.agent_index)
        board.offer(i, decision.episode, decision.step, decision.action)
    return actors, send


def test_decentralised_episodes_equal_central_policy():
    """Per-robot actors with their own hidden states decide exactly as the shared actor on the
    whole batch, across episode boundaries (hidden reset on episode_start)."""
    env = make_env_logic()
    policy = make_policy(env)
    central = run_episodes(env, CentralPolicy(policy), episodes=3, seed=5)
    board = ChoiceBoard(["tb3_0", "tb3_1"])
    _, send = in_process_actors(policy, board, env.n_agents)
    decentral = run_episodes(make_env_logic(), DecentralisedPolicy(env.n_agents, send, board, timeout=5.0),
                             episodes=3, seed=5)
    assert [r.makespan for r in decentral] == [r.makespan for r in central]
    assert [r.robot_task_lists() for r in decentral] == [r.robot_task_lists() for r in central]
    assert sum(r.decision_steps for r in central) > 6


def test_hidden_state_resets_at_episode_start_and_repeats_do_not_advance():
    env = make_env_logic()
    policy = make_policy(env)
    actor = RobotActor(policy, 1)
    first = env.reset(seed=0)
    obs, mask = first.obs[1], first.action_mask[1].astype(np.uint8)
    a0 = actor.decide(0, 0, True, obs, mask, 1)
    h_after_first = actor.hidden.clone()
    again = actor.decide(0, 0, True, obs, mask, 1)
    assert again.repeated and again.action == a0.action
    assert torch.equal(actor.hidden, h_after_first)
    actor.decide(0, 1, False, obs, mask, 1)
    assert not torch.equal(actor.hidden, h_after_first)       # state carried within an episode
    actor.decide(1, 0, True, obs, mask, 1)
    assert torch.equal(actor.hidden, h_after_first)            # reset: same as the first decision


def test_mask_honoured_and_bad_rows_rejected():
    env = make_env_logic()
    policy = make_policy(env)
    actor = RobotActor(policy, 0)
    obs = env.reset(seed=0).obs[0]
    for allowed in range(env.n_actions):
        mask = np.zeros(env.n_actions, dtype=np.uint8)
        mask[allowed] = 1
        assert actor.decide(allowed, 0, True, obs, mask, 0).action == allowed
    with pytest.raises(ObservationError, match="obs: 3 values"):
        actor.decide(99, 0, True, [0.0, 1.0, 2.0], b"", 0)
    with pytest.raises(ObservationError, match="agent_index"):
        actor.decide(99, 0, True, obs, b"", 1)
    with pytest.raises(ObservationError, match="agent_index"):
        RobotActor(policy, env.n_agents)


def test_board_ignores_stale_choices_and_times_out_naming_the_silent_robot():
    board = ChoiceBoard(["tb3_0", "tb3_1"])
    board.expect(2, 4)
    board.offer(0, 2, 3, 1)          # a late answer to the previous step
    board.offer(1, 2, 4, 5)
    polls = []
    with pytest.raises(ActorTimeout, match=r"^tb3_0: no task_choice within 0.3 s for episode 2 step 4"):
        board.wait(0.3, poll=0.05, on_poll=lambda: polls.append(1))
    assert polls                      # observations are re-sent while waiting
    board.expect(2, 5)
    threading.Timer(0.05, board.offer, (0, 2, 5, 7)).start()
    board.offer(1, 2, 5, 8)
    assert board.wait(5.0, poll=0.01) == [7, 8]
