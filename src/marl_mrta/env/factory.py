"""Build a task-allocation environment from a scenario file and the package's configuration."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Optional, Union

from marl_mrta.model.goal_timeout import LegTimeouts, TimeoutValue, auto_episode_timeout, check_goal_timeout
from marl_mrta.model.scenario import Scenario, ScenarioError, load_scenario
from marl_mrta.common.config import ConfigError
from marl_mrta.model.reward import RewardConfig
from marl_mrta.model.travel import TravelTable, nominal_travel_table
from marl_mrta.env.embedded import EmbeddedExecutor
from marl_mrta.env.executor import Executor
from marl_mrta.env.event_env import EventTaskEnvironment
from marl_mrta.env.settings import (DECISION_MODES, MASK_MODES, TaskSettings, load_embedded_settings,
                                    load_task_settings)
from marl_mrta.env.task_env import TaskEnvironment

#: Executors an environment can be built with here (the ROS executor lives with the ROS nodes).
EXECUTORS = ("embedded",)


def scenario_travel_table(scenario: Scenario, embedded_config: Optional[Union[str, Path]] = None) -> TravelTable:
    """The nominal travel-time table of a scenario under the configured travel model."""
    return nominal_travel_table(scenario, load_embedded_settings(embedded_config).travel)


def scenario_leg_timeouts(scenario: Scenario, task_config: Optional[Union[str, Path]] = None,
                          goal_timeout: Optional[TimeoutValue] = None,
                          embedded_config: Optional[Union[str, Path]] = None) -> LegTimeouts:
    """Each leg's own goal timeout on `scenario`, under the rule make_env gives its environment
    with the same arguments, from the scenario's travel table (the one make_env and the planners
    use): what the ROS executors keep per episode."""
    rule = load_task_settings(task_config).for_scenario(scenario, check_goal_timeout(goal_timeout, "goal_timeout"))
    table = scenario_travel_table(scenario, embedded_config) if rule.goal_timeout.auto else None
    return LegTimeouts(rule.goal_timeout, scenario.n_robots, table.nominal_time if table is not None else None)


def resolved_scenario(scenario: Scenario, settings: TaskSettings,
                      embedded_config: Optional[Union[str, Path]] = None) -> Scenario:
    """The scenario as its episodes run under `settings`: an auto episode timeout computed from
    the travel table (`episode_timeout_factor` × the sum over tasks of the shortest leg into the
    task and its service time), and the goal timeout in force as its goal_timeout."""
    timeout = scenario.episode_timeout
    if timeout is None:
        table = scenario_travel_table(scenario, embedded_config)
        timeout = auto_episode_timeout(table.nominal_time, scenario.n_robots,
                                       [t.service_time for t in scenario.tasks], settings.episode_timeout_factor)
    goal_timeout = settings.goal_timeout.value
    if (timeout, goal_timeout) == (scenario.episode_timeout, scenario.goal_timeout):
        return scenario
    return replace(scenario, episode_timeout=timeout, goal_timeout=goal_timeout)


def make_env(scenario: Union[str, Path, Scenario], executor: Union[str, Executor] = "embedded", *,
             profile: Optional[str] = None, mask: Optional[str] = None, seed: Optional[int] = None,
             reward_config: Optional[Union[str, Path]] = None, task_config: Optional[Union[str, Path]] = None,
             embedded_config: Optional[Union[str, Path]] = None,
             hold_successors: Optional[bool] = None, precedence_margin: float = 0.0,
             decision_mode: Optional[str] = None,
             goal_timeout: Optional[TimeoutValue] = None) -> Union[TaskEnvironment, EventTaskEnvironment]:
    """An environment on `scenario` (file or loaded Scenario).

    executor: "embedded", or an Executor object (e.g. the ROS executor) that moves the robots;
    profile: a noise profile of config/noise_profiles.yaml (default: its `profile`; embedded
    only); mask: none | finished | logic (default: config/task.yaml); hold_successors: the rule
    of model/rules.py (default: config/task.yaml); precedence_margin: s a successor must be
    reached after its predecessor's finish to count as in order (a model planning with a margin); decision_mode:
    synchronous | event (default: config/task.yaml; event needs an executor with the event interface, or
    embedded); goal_timeout: seconds or 'auto', over the scenario's <episode goal_timeout> and
    config/task.yaml's (default: theirs); seed: of the first reset() without a seed. The
    environment's scenario has its episode timeout as a number (an auto one computed here) and the
    goal timeout in force as its goal_timeout. Raises ScenarioError or ConfigError with a one-line
    message.
    """
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    if isinstance(executor, str) and executor not in EXECUTORS:
        raise ConfigError(f"executor: {executor!r} is not one of {', '.join(EXECUTORS)}")
    settings = load_task_settings(task_config).for_scenario(scenario, check_goal_timeout(goal_timeout, "goal_timeout"))
    if mask is not None:
        if mask not in MASK_MODES:
            raise ConfigError(f"mask: {mask!r} is not one of {', '.join(MASK_MODES)}")
        settings = replace(settings, mask=mask)
    if hold_successors is not None:
        settings = replace(settings, hold_successors=hold_successors)
    if precedence_margin:
        settings = replace(settings, precedence_margin=float(precedence_margin))
    if decision_mode is not None:
        if decision_mode not in DECISION_MODES:
            raise ConfigError(f"decision_mode: {decision_mode!r} is not one of {', '.join(DECISION_MODES)}")
        settings = replace(settings, decision_mode=decision_mode)
    if scenario.live and settings.decision_mode != "event":   # the paper's steps have no instant for them
        raise ScenarioError(f"{scenario.source}: <task release> and <faults> change the fleet while it works, which "
                            "event mode alone does: run it with decision_mode event (--decision-mode event)")
    environment = EventTaskEnvironment if settings.decision_mode == "event" else TaskEnvironment
    scenario = resolved_scenario(scenario, settings, embedded_config)
    try:
        reward = RewardConfig.load(scenario.nav_thresholds, reward_config, scenario.reward_overrides)
    except ConfigError as error:
        raise ScenarioError(f"{scenario.source}: <reward>: {error}") from None
    embedded = load_embedded_settings(embedded_config)
    # Event mode keeps the travel model: a live fleet plans the goals of tasks submitted to it.
    extra = {"travel_model": embedded.travel} if environment is EventTaskEnvironment else {}
    if not isinstance(executor, str):
        return environment(scenario, executor, reward, settings, seed, **extra)
    table = nominal_travel_table(scenario, embedded.travel)
    runner = EmbeddedExecutor(table, scenario.n_robots, embedded.profile(profile), settings.goal_timeout, seed,
                              embedded.collision_distance, embedded.collision_dt)
    return environment(scenario, runner, reward, settings, seed, **extra)
