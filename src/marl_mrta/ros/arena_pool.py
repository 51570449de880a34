"""The task managers of K arenas of one simulator as one pool of environments for training.

Each arena's rl_task_allocation_manager is an environment (env_client.py), scored with the
run's training reward (mappo/training_env.py), stepped in parallel threads and, being a
simulation, not replayed on resume.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Tuple

from marl_mrta.mappo.config import MappoConfig
from marl_mrta.mappo.env_pool import EnvPool
from marl_mrta.mappo.runner import RunError
from marl_mrta.mappo.training_env import TrainingRewardEnv, training_reward
from marl_mrta.model.goal_timeout import TimeoutValue, describe_timeout
from marl_mrta.ros.env_client import ManagerUnavailable, RosTaskEnvClient, arena_managers


def arena_pool(config: MappoConfig, seed: int, scenario: Optional[str], manager_wait: float,
               goal_timeout: Optional[TimeoutValue] = None) -> Tuple[EnvPool, str]:
    """The running task managers of config.n_envs arenas as a parallel EnvPool, and the scenario
    file they run; checks that they run `scenario` (when given), the mask the settings expect and
    `goal_timeout` (seconds or 'auto', when given)."""
    import rosgraph
    if not rosgraph.is_master_online():
        raise ManagerUnavailable(f"no ROS master at {rosgraph.get_master_uri()}: start the arenas first "
                                 f"(roslaunch marl_mrta tasks.launch arenas:={config.n_envs} mask:={config.action_mask}, "
                                 f"or train with roslaunch marl_mrta train.launch backend:=ros)")
    clients = [RosTaskEnvClient(name, wait_wall=manager_wait) for name in arena_managers(config.n_envs)]
    first = clients[0]
    for client in clients:
        check_manager(client, first, config, scenario)
        if goal_timeout is not None and client.settings.goal_timeout.value != goal_timeout:
            raise RunError(f"{client.manager}: goal_timeout: the manager's is "
                           f"{describe_timeout(client.settings.goal_timeout.value)}, the training asks for "
                           f"{describe_timeout(goal_timeout)} (start it with goal_timeout:={goal_timeout})")
    reward = training_reward(first.scenario, config.reward_overrides)
    envs = [TrainingRewardEnv(client, reward, client.n_tasks) for client in clients]
    return EnvPool(envs, seed, parallel=True, replayable=False), str(first.scenario_path)


def check_manager(client, first, config: MappoConfig, scenario: Optional[str]) -> None:
    """RunError (one line) unless an arena's manager runs what the run trains for: `scenario`
    (when given) and the first arena's, the settings' action mask and hold_successors."""
    source = client.scenario_path
    if scenario is not None and source != Path(scenario).resolve():
        raise RunError(f"{client.manager}: runs scenario {source}, the training is for {scenario}")
    if client.settings.mask != config.action_mask:
        raise RunError(f"{client.manager}: mask: the manager masks {client.settings.mask!r}, the settings "
                       f"train with action_mask {config.action_mask!r} (start it with mask:={config.action_mask})")
    if client.settings.hold_successors != config.hold_successors:
        raise RunError(f"{client.manager}: hold_successors: the manager's is {client.settings.hold_successors}, the "
                       f"settings train with {config.hold_successors} (start it with "
                       f"hold_successors:={str(config.hold_successors).lower()})")
    if source != first.scenario_path:
        raise RunError(f"{client.manager}: runs scenario {source}, {first.manager} runs {first.scenario_path}")
