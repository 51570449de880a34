"""Rewards of the training settings for an environment that scores with its own reward.

Training may replace reward values (`reward_overrides`, e.g. the tuned preset's nav.best 0).
An embedded environment is simply built with them; a task manager in the ROS simulation
scores with the package's reward file. TrainingRewardEnv recomputes each step's rewards from
the step's info (what each robot did: task or None, order, finished, navigation, collision
and idle time) with tasks/reward.py, the one implementation of the reward, so both backends
train on the same reward.
"""
from __future__ import annotations

import dataclasses
from typing import Mapping, Optional, Sequence

import numpy as np

from ..env.api import StepOutput, TaskAllocationEnv
from ..scenario import Scenario
from ..tasks.reward import RewardConfig, step_rewards


def training_reward(scenario: Scenario, overrides: Mapping[str, Mapping[str, float]]) -> RewardConfig:
    """config/reward.yaml, then the scenario's <reward>, then the training overrides."""
    merged = {section: dict(values) for section, values in scenario.reward_overrides.items()}
    for section, values in overrides.items():
        merged.setdefault(section, {}).update(values)
    return RewardConfig.load(scenario.nav_thresholds, None, merged)


class TrainingRewardEnv:
    """`env` with every step's rewards and reward components recomputed under `reward`."""

    def __init__(self, env: TaskAllocationEnv, reward: RewardConfig, n_tasks: int):
        self.env = env
        self.reward = reward
        self.n_tasks = n_tasks
        self.n_agents, self.n_actions = env.n_agents, env.n_actions
        self.obs_dim, self.state_dim = env.obs_dim, env.state_dim
        self.scenario = env.scenario

    def reset(self, seed: Optional[int] = None) -> StepOutput:
        return self.env.reset(seed=seed)

    def step(self, actions: Sequence[int]) -> StepOutput:
        out = self.env.step(actions)
        info = out.info
        has_task = [int(a) != self.n_tasks for a in actions]
        finished = [task is not None for task in info["finished_task"]]
        breakdown = step_rewards(self.reward, has_task, info["correct_order"], finished, info["nav_time"],
                                 info["collisions"], info["idle_time"])
        components = {name: np.asarray(getattr(breakdown, name), dtype=np.float32) for name in out.reward_components}
        return dataclasses.replace(out, rewards=np.asarray(breakdown.total, dtype=np.float32),
                                   reward_components=components)
