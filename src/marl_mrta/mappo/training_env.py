"""The environments a MAPPO run trains on, scored with the run's training reward.

Training may replace reward values (`reward_overrides`, e.g. the tuned preset's nav.best 0) on
top of the scenario's own <reward>. An embedded environment is simply built with them
(`embedded_factory`); a task manager in the ROS simulation scores with the package's reward
file, so TrainingRewardEnv recomputes each step's rewards from the step's information (what each
robot did: task or None, order, finished, navigation, collision and idle time) with
model/reward.py, the one implementation of the reward: both backends train on the same reward.
"""
from __future__ import annotations

import dataclasses
from functools import partial
from typing import Callable, Mapping, Optional, Sequence, Union

import numpy as np

from marl_mrta.env.api import StepOutput, TaskAllocationEnv
from marl_mrta.env.factory import make_env
from marl_mrta.mappo.config import MappoConfig
from marl_mrta.model.reward import RewardConfig, merge_reward_overrides, step_rewards
from marl_mrta.model.scenario import Scenario, load_scenario


def with_training_reward(scenario: Scenario, overrides: Mapping[str, Mapping[str, float]]) -> Scenario:
    """The scenario with the training settings' reward overrides over its own <reward>."""
    return dataclasses.replace(scenario, reward_overrides=merge_reward_overrides(scenario.reward_overrides, overrides))


def training_reward(scenario: Scenario, overrides: Mapping[str, Mapping[str, float]]) -> RewardConfig:
    """config/reward.yaml, then the scenario's <reward>, then the training overrides."""
    trained = with_training_reward(scenario, overrides)
    return RewardConfig.load(trained.nav_thresholds, None, trained.reward_overrides)


def embedded_factory(scenario: Union[str, Scenario], config: MappoConfig) -> Callable[[], TaskAllocationEnv]:
    """A function building one embedded environment of the run (the scenario is parsed once);
    bad settings fail here, before any training."""
    loaded = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    build = partial(make_env, with_training_reward(loaded, config.reward_overrides), "embedded",
                    profile=config.noise_profile, mask=config.action_mask)
    build()
    return build


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
        finished = [task is not None for task in info.finished_task]
        breakdown = step_rewards(self.reward, has_task, info.correct_order, finished, info.nav_time,
                                 info.collisions, info.idle_time)
        components = {name: np.asarray(getattr(breakdown, name), dtype=np.float32) for name in out.reward_components}
        return dataclasses.replace(out, rewards=np.asarray(breakdown.total, dtype=np.float32),
                                   reward_components=components)
