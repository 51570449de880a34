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
from typing import Callable, Dict, Mapping, Optional, Sequence, Union

import numpy as np

from marl_mrta.env.api import StepOutput, TaskAllocationEnv
from marl_mrta.env.factory import make_env
from marl_mrta.mappo.claims import is_sequential
from marl_mrta.mappo.config import MappoConfig
from marl_mrta.mappo.env_pool import EnvPool
from marl_mrta.mappo.set_view import SetViewEnv
from marl_mrta.model.reward import RewardConfig, merge_reward_overrides, step_rewards
from marl_mrta.model.scenario import Scenario, load_scenario


def with_training_reward(scenario: Scenario, overrides: Mapping[str, Mapping[str, float]]) -> Scenario:
    """The scenario with the training settings' reward overrides over its own <reward>."""
    return dataclasses.replace(scenario, reward_overrides=merge_reward_overrides(scenario.reward_overrides, overrides))


def training_reward(scenario: Scenario, overrides: Mapping[str, Mapping[str, float]]) -> RewardConfig:
    """config/reward.yaml, then the scenario's <reward>, then the training overrides."""
    trained = with_training_reward(scenario, overrides)
    return RewardConfig.load(trained.nav_thresholds, None, trained.reward_overrides)


def run_overrides(scenario: Scenario, config: MappoConfig) -> Dict[str, Dict[str, float]]:
    """The reward overrides a run trains `scenario` with: the settings' reward_overrides and, with
    match_time_costs, the nav.slope at which a second of driving costs w_idle·|idle.per_second|,
    what a second of waiting costs (w_time·slope/t_avg per second of driving), from the weights
    in force for this scenario."""
    overrides = {section: dict(values) for section, values in config.reward_overrides.items()}
    if not config.match_time_costs:
        return overrides
    reward = training_reward(scenario, overrides)
    slope = reward.w_idle * abs(reward.idle_per_second) * reward.thresholds.t_avg / reward.w_time
    return merge_reward_overrides(overrides, {"nav": {"slope": slope}})


def embedded_factory(scenario: Union[str, Scenario], config: MappoConfig) -> Callable[[], TaskAllocationEnv]:
    """A function building one embedded environment of the run (the scenario is parsed once);
    bad settings fail here, before any training."""
    loaded = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    build = partial(make_env, with_training_reward(loaded, run_overrides(loaded, config)), "embedded",
                    profile=config.noise_profile, mask=config.action_mask, hold_successors=config.hold_successors,
                    decision_mode=config.decision_mode)
    build()
    return build


def set_view_pool(config: MappoConfig, scenarios: Sequence[Union[str, Scenario]], seed: int) -> EnvPool:
    """The run's pool for the set actor (mappo/set_view.py): config.n_envs embedded environments,
    each running the scenarios in turn (one per episode, chosen by the episode's seed), padded to
    the largest scenario's robots and tasks. Every scenario is loaded and checked here."""
    loaded = [s if isinstance(s, Scenario) else load_scenario(s) for s in scenarios]
    builds = [embedded_factory(s, config) for s in loaded]
    robot_slots = max(s.n_robots for s in loaded)
    task_slots = max(s.n_tasks for s in loaded)
    sequential = is_sequential(config.decision_order)
    envs = [SetViewEnv(lambda i: builds[i](), len(loaded), robot_slots, task_slots, sequential,
                       turn_order=config.turn_order)
            for _ in range(config.n_envs)]
    return EnvPool(envs, seed, mixed=len(loaded) > 1)


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
