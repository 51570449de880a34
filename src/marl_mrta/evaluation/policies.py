"""Decision makers the evaluation runs through the environment: plans, learned actors.

Every one offers begin_episode(first_output, episode) and act(output) -> one action per robot.
"""
from __future__ import annotations

from typing import List, Optional

import numpy as np

from marl_mrta.baselines.plan import Plan
from marl_mrta.env.api import StepOutput
from marl_mrta.mappo.policy import ActorPolicy, PolicyFileError, load_policy


class PlanPolicy:
    """Replays a plan's joint actions; if tasks are still open when they run out (a failed
    goal under noise), each robot heads for the next open task of its own list, and a robot
    with none left takes an open task no one else is heading for."""

    def __init__(self, plan: Plan, n_agents: int, n_tasks: int):
        self.name = plan.method
        self.plan = plan
        self.n_agents = n_agents
        self.n_tasks = n_tasks
        self._step = 0

    def begin_episode(self, first: StepOutput, episode: Optional[int] = None) -> None:
        self._step = 0

    def act(self, output: StepOutput) -> List[int]:
        none = self.n_tasks
        step, self._step = self._step, self._step + 1
        if step < len(self.plan.joint_actions):
            return [none if a is None else a for a in self.plan.joint_actions[step]]
        finished = output.info.finished
        actions = []
        for tasks in self.plan.robot_tasks:
            open_tasks = [t for t in tasks if not finished[t]]
            actions.append(open_tasks[0] if open_tasks else none)
        spare = [j for j in range(self.n_tasks) if not finished[j] and j not in actions]
        for robot in range(self.n_agents):
            if actions[robot] == none and spare:
                actions[robot] = spare.pop(0)
        return actions


class PolicyLoadError(ValueError):
    """The learned policy cannot be used here; str(error) is one line."""


class LearnedPolicy:
    """A trained MAPPO actor (mappo/policy.py's ActorPolicy) deciding for the whole team, one
    recurrent state per robot, greedy unless deterministic is False."""

    name = "policy"

    def __init__(self, actor: ActorPolicy, n_agents: int, deterministic: bool = True):
        self.actor = actor
        self.n_agents = n_agents
        self.deterministic = deterministic
        self._hidden = None

    @classmethod
    def from_file(cls, path: str, n_agents: int, obs_dim: int, n_actions: int, seed: int = 0,
                  deterministic: bool = True) -> "LearnedPolicy":
        """The actor of an actor file, checked against the environment's sizes."""
        try:
            actor = load_policy(path, seed=seed)
        except PolicyFileError as error:
            raise PolicyLoadError(str(error)) from None
        if actor.obs_dim != obs_dim or actor.n_actions != n_actions:
            raise PolicyLoadError(f"{path}: the actor expects observations of {actor.obs_dim} values and "
                                  f"{actor.n_actions} actions; this scenario has {obs_dim} and {n_actions}")
        return cls(actor, n_agents, deterministic)

    def begin_episode(self, first: StepOutput, episode: Optional[int] = None) -> None:
        self._hidden = self.actor.initial_hidden(self.n_agents)

    def act(self, output: StepOutput) -> List[int]:
        actions, self._hidden = self.actor.act_team(output.obs, output.action_mask, self._hidden,
                                                    deterministic=self.deterministic)
        return [int(a) for a in np.asarray(actions).reshape(-1)]
