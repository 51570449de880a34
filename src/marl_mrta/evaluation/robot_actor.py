"""One robot's decision maker at run time (decentralised execution, scripts/robot_actor).

RobotActor holds a trained actor (mappo.policy.load_policy) and this robot's own recurrent
state; it sees only this robot's observation and answers with this robot's task, from the
actor alone or looking ahead (evaluation/lookahead.py). No rospy here: the node shell feeds it
RobotObservation messages and publishes its TaskChoice. in_process_team: the same robots
answering through the evaluation's DecentralisedPolicy without ROS.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from marl_mrta.evaluation.decentralised import ChoiceBoard, DecentralisedPolicy, ObservationRow
from marl_mrta.evaluation.lookahead import Lookahead, LookaheadChoice
from marl_mrta.mappo.policy import ActorPolicy


class ObservationError(ValueError):
    """An observation this actor cannot act on; str(error) is one line naming the field."""


@dataclass(frozen=True)
class Decision:
    """This robot's answer to one observation."""

    episode: int
    step: int
    action: int
    repeated: bool   # the same (episode, step) was already answered: the stored action, state unchanged


class RobotActor:
    """A shared actor acting for robot `agent_index` only, with its own GRU hidden state;
    with `lookahead`, each choice is this robot's part of the team's step the lookahead searched
    from this robot's observation."""

    def __init__(self, policy, agent_index: int, lookahead: Optional[Lookahead] = None):
        if not 0 <= agent_index < policy.n_agents:
            raise ObservationError(f"agent_index: {agent_index} outside 0..{policy.n_agents - 1} "
                                   f"(the actor was trained for {policy.n_agents} robots)")
        self.policy = policy
        self.agent_index = agent_index
        self.lookahead = lookahead
        self.looked: Optional[LookaheadChoice] = None   # the last decision's lookahead
        self.hidden = policy.initial_hidden(1)
        self._last: Optional[Decision] = None

    def decide(self, episode: int, step: int, episode_start: bool, obs: Sequence[float],
               action_mask: Sequence[int], agent_index: int, claimed: Sequence[int] = b"") -> Decision:
        """One decision. A repeated (episode, step), e.g. a re-sent observation, gets the same
        answer without advancing the recurrent state; episode_start resets it first. claimed:
        per task, 1 = taken earlier in this step (a sequential policy; empty = none)."""
        if self._last is not None and (self._last.episode, self._last.step) == (episode, step):
            return Decision(episode, step, self._last.action, repeated=True)
        if agent_index != self.agent_index:
            raise ObservationError(f"agent_index: observation for robot {agent_index}, this actor is robot "
                                   f"{self.agent_index}")
        obs_row, mask_row = self._rows(obs, action_mask)
        claimed_row = self._claimed(claimed)
        if episode_start:
            self.hidden = self.policy.initial_hidden(1)
        if self.lookahead is None:
            actions, self.hidden = self.policy.act(obs_row, mask_row, self.hidden, deterministic=True,
                                                   agent_ids=[self.agent_index], claimed=claimed_row)
            action = int(actions[0])
        else:
            logits, mask_t, self.hidden = self.policy.logits(obs_row, mask_row, self.hidden, [self.agent_index],
                                                             claimed_row)
            self.looked = self.lookahead.choose(self.agent_index, obs_row[0], logits[0], mask_t[0],
                                                None if claimed_row is None else claimed_row[0])
            action = self.looked.action
        self._last = Decision(episode, step, action, repeated=False)
        return self._last

    def _claimed(self, claimed: Sequence[int]) -> Optional[np.ndarray]:
        flags = np.frombuffer(bytes(claimed), dtype=np.uint8) if isinstance(claimed, (bytes, bytearray)) \
            else np.asarray(claimed, dtype=np.uint8)
        if flags.size == 0:
            return None
        n_tasks = self.policy.n_actions - 1
        if flags.size != n_tasks:
            raise ObservationError(f"claimed: {flags.size} values, the scenario has {n_tasks} tasks")
        if not self.policy.sequential:
            raise ObservationError("claimed: given, but this policy decides simultaneously (decision_order)")
        return flags.reshape(1, -1)   # claimers (k + 1 = robot k's): the set actor reads whose trip it is

    def _rows(self, obs: Sequence[float], action_mask: Sequence[int]) -> Tuple[np.ndarray, Optional[np.ndarray]]:
        obs_row = np.asarray(obs, dtype=np.float32).reshape(1, -1)
        if obs_row.shape[1] != self.policy.obs_dim:
            raise ObservationError(f"obs: {obs_row.shape[1]} values, the actor expects {self.policy.obs_dim}")
        mask = np.frombuffer(bytes(action_mask), dtype=np.uint8) if isinstance(action_mask, (bytes, bytearray)) \
            else np.asarray(action_mask, dtype=np.uint8)
        if mask.size == 0:
            return obs_row, None
        if mask.size != self.policy.n_actions:
            raise ObservationError(f"action_mask: {mask.size} values, the actor has {self.policy.n_actions} actions")
        if not mask.any():
            raise ObservationError("action_mask: no action allowed")
        return obs_row, mask.astype(bool).reshape(1, -1)


def in_process_team(policy: ActorPolicy, lookahead: Optional[Lookahead] = None) -> DecentralisedPolicy:
    """The robots' own actors (one RobotActor each, as their nodes) answering the evaluation
    runner in this process: each sent only its own row, in the actor's turn order."""
    names = [f"robot_{i}" for i in range(policy.n_agents)]
    board = ChoiceBoard(names)
    actors = [RobotActor(policy, i, lookahead) for i in range(policy.n_agents)]

    def send(robot: int, row: ObservationRow) -> None:
        decision = actors[robot].decide(row.episode, row.step, row.episode_start, row.obs, row.action_mask.tobytes(),
                                        row.agent_index, row.claimed.tobytes())
        board.offer(robot, decision.episode, decision.step, decision.action)

    turns = policy.turns if policy.sequential and policy.turn_order != "index" else None
    team = DecentralisedPolicy(policy.n_agents, send, board, timeout=60.0,
                               claim_rules=policy.claim_rules if policy.sequential else None, turns=turns)
    team.name = "lookahead" if lookahead is not None else "policy"
    return team
