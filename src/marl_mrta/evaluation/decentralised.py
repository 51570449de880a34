"""The robots' side of decentralised execution, without ROS: what each robot is sent
(ObservationRow), the board that collects their choices, and the policy the evaluation
runner asks, which sends each robot only its own row and waits for every choice. The
transport is given as callables (ros/actor_links.py: topics; tests: in-process actors).
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Sequence

import numpy as np
import torch

from marl_mrta.env.api import StepOutput
from marl_mrta.mappo.claims import ClaimRules, busy_claims

#: Topics relative to each robot's namespace.
OBSERVATION_TOPIC = "task_observation"
CHOICE_TOPIC = "task_choice"
#: Name of the actor node inside a robot's namespace (launch/execute.launch).
ACTOR_NODE = "robot_actor"


class ActorTimeout(RuntimeError):
    """A robot's actor did not answer (or is not there); str(error) is one line."""


@dataclass(frozen=True)
class ObservationRow:
    """What one robot is sent for one decision (msg/RobotObservation.msg)."""

    episode: int
    step: int
    episode_start: bool
    obs: np.ndarray           # (obs_dim,) float32
    action_mask: np.ndarray   # (n_actions,) uint8
    agent_index: int
    claimed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.uint8))  # (n_tasks,) sequential; else empty


class ChoiceBoard:
    """Collects the robots' choices for the step being decided; thread-safe (subscriber callbacks)."""

    def __init__(self, robot_names: Sequence[str]):
        self.robot_names = list(robot_names)
        self._cond = threading.Condition()
        self._key = (-1, -1)
        self._choices: List[Optional[int]] = [None] * len(self.robot_names)

    def expect(self, episode: int, step: int) -> None:
        """Forget earlier choices; from now on only answers to (episode, step) count."""
        with self._cond:
            self._key = (episode, step)
            self._choices = [None] * len(self.robot_names)

    def offer(self, robot_index: int, episode: int, step: int, action: int) -> None:
        """A robot's answer; answers to another step (late or repeated) are ignored."""
        with self._cond:
            if (episode, step) != self._key:
                return
            self._choices[robot_index] = int(action)
            self._cond.notify_all()

    def wait(self, timeout: float, poll: float = 1.0, on_poll: Callable[[], None] = lambda: None,
             stop: Callable[[], bool] = lambda: False, robots: Optional[Sequence[int]] = None) -> List[Optional[int]]:
        """The actions of `robots` (default every robot) for the expected step; on_poll() every
        `poll` s while waiting (re-sending observations); ActorTimeout naming the silent robots
        after `timeout` wall s. Robots not waited for may still be None."""
        deadline = time.monotonic() + timeout
        waited = range(len(self.robot_names)) if robots is None else list(robots)
        with self._cond:
            while any(self._choices[i] is None for i in waited):
                remaining = deadline - time.monotonic()
                if remaining <= 0 or stop():
                    missing = [self.robot_names[i] for i in waited if self._choices[i] is None]
                    why = "shutdown" if stop() else f"no {CHOICE_TOPIC} within {timeout:g} s"
                    raise ActorTimeout(f"{', '.join(missing)}: {why} for episode {self._key[0]} step "
                                       f"{self._key[1]} (is each robot's {ACTOR_NODE} running?)")
                if not self._cond.wait(min(poll, remaining)):
                    self._cond.release()
                    try:
                        on_poll()
                    finally:
                        self._cond.acquire()
            return [None if c is None else int(c) for c in self._choices]


class DecentralisedPolicy:
    """The evaluation runner's decision-maker interface (begin_episode, act) answered by the
    robots' actors: each gets its own observation row, none sees another's."""

    name = "decentralised"

    def __init__(self, n_agents: int, send: Callable[[int, ObservationRow], None], board: ChoiceBoard,
                 timeout: float, resend_period: float = 1.0, stop: Callable[[], bool] = lambda: False,
                 claim_rules: Optional[ClaimRules] = None,
                 turns: Optional[Callable[[np.ndarray], torch.Tensor]] = None):
        """claim_rules: the actors decide one after another, each told the tasks claimed before
        it (mappo/claims.py, the paper's assigned-task list); None: all at once. turns(every
        robot's observation row): the robots in the order they answer (the actors' turn order,
        SetView.turns); None: index order."""
        self.n_agents = n_agents
        self.claim_rules = claim_rules
        self.turns = turns
        self.send = send
        self.board = board
        self.timeout = timeout
        self.resend_period = resend_period
        self.stop = stop
        self.episode = -1
        self.step = 0

    def begin_episode(self, first: StepOutput, episode: Optional[int] = None) -> None:
        self.episode = self.episode + 1 if episode is None else int(episode)
        self.step = 0

    def act(self, output: StepOutput) -> List[int]:
        # Event mode: only the robots that decide now are asked; the others drive on (None).
        asked = list(range(self.n_agents)) if output.deciding is None else \
            [i for i in range(self.n_agents) if output.deciding[i]]
        if self.claim_rules is not None and self.claim_rules.sequential:
            return self._act_in_turn(output, asked)
        rows = {i: ObservationRow(episode=self.episode, step=self.step, episode_start=self.step == 0,
                                  obs=np.asarray(output.obs[i], dtype=np.float32),
                                  action_mask=np.asarray(output.action_mask[i], dtype=np.uint8),
                                  agent_index=i) for i in asked}
        self.board.expect(self.episode, self.step)

        def send_all() -> None:
            for i, row in rows.items():
                self.send(i, row)

        send_all()
        # A lost message is re-sent; the actors answer a repeated step without re-deciding.
        answers = self.board.wait(self.timeout, self.resend_period, on_poll=send_all, stop=self.stop, robots=asked)
        self.step += 1
        none = output.action_mask.shape[-1] - 1
        return [int(answers[i]) if i in rows else none for i in range(self.n_agents)]

    def _act_in_turn(self, output: StepOutput, asked: Sequence[int]) -> List[int]:
        """A robot is asked once the robots before it (turns) have answered, with the tasks they
        claimed (event mode: the tasks of busy robots claimed from the start)."""
        self.board.expect(self.episode, self.step)
        none = output.action_mask.shape[-1] - 1
        claimed = None if output.deciding is None else busy_claims(output.info.robot_tasks, output.deciding, none)

        def ask(turn: torch.Tensor, claimed: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
            robot = int(turn)
            if robot not in asked:
                return torch.tensor(none, dtype=torch.long)
            row = ObservationRow(episode=self.episode, step=self.step, episode_start=self.step == 0,
                                 obs=np.asarray(output.obs[robot], dtype=np.float32),
                                 action_mask=mask.numpy().astype(np.uint8), agent_index=robot,
                                 claimed=claimed.numpy().astype(np.uint8))
            self.send(robot, row)
            answers = self.board.wait(self.timeout, self.resend_period, on_poll=lambda: self.send(robot, row),
                                      stop=self.stop, robots=[robot])
            return torch.tensor(answers[robot], dtype=torch.long)

        actions = self.claim_rules.decide_in_turn(torch.as_tensor(np.asarray(output.action_mask, dtype=bool)), ask,
                                                  None if self.turns is None
                                                  else self.turns(np.asarray(output.obs, dtype=np.float32)),
                                                  claimed)
        self.step += 1
        return [int(a) for a in actions]
