"""The reward of SPEC "Reward", one implementation for every executor.

    R_i = w_logic·r_logic + w_time·r_nav + w_col·r_col + w_idle·r_idle

Every value comes from config/reward.yaml, optionally overridden per scenario (the scenario's
<reward> element); the r_nav thresholds t_min, t_avg, t_max come from the scenario.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

from marl_mrta.common.config import ConfigError, ConfigSection, read_yaml
from marl_mrta.common.paths import default_config_path
from marl_mrta.common.records import STEP_RECORD

#: The keys of config/reward.yaml (section -> keys); scenario overrides use the same names.
REWARD_SCHEMA: Dict[str, Tuple[str, ...]] = {
    "weights": ("logic", "time", "idle", "collision"),
    "logic": ("correct_finished", "correct_unfinished", "wrong_finished", "wrong_unfinished", "no_task"),
    "nav": ("best", "slope", "at_or_below_min", "at_or_over_max", "no_task"),
    "collision": ("per_event",),
    "idle": ("per_second",),
}


@dataclass(frozen=True)
class NavThresholds:
    """The r_nav time thresholds of a scenario, seconds."""

    t_min: float
    t_avg: float
    t_max: float


@dataclass(frozen=True)
class RewardConfig:
    w_logic: float
    w_time: float
    w_idle: float
    w_col: float
    logic_correct_finished: float      # right order, this robot finished the task
    logic_correct_unfinished: float    # right order, not finished by this robot
    logic_wrong_finished: float        # predecessor missing, finished anyway
    logic_wrong_unfinished: float      # predecessor missing, not finished
    logic_no_task: float               # action None
    nav_best: float                    # r_nav = best − slope·(t − t_min)/t_avg inside (t_min, t_max)
    nav_slope: float
    nav_at_or_below_min: float         # r_nav at t <= t_min (a trip to where the robot already is)
    nav_at_or_over_max: float          # r_nav at t >= t_max
    nav_no_task: float                 # action None: no navigation to score
    col_per_event: float
    idle_per_second: float
    thresholds: NavThresholds

    @staticmethod
    def load(thresholds: NavThresholds, path: Optional[Union[str, Path]] = None,
             overrides: Optional[Mapping[str, Mapping[str, float]]] = None) -> "RewardConfig":
        """config/reward.yaml (or `path`) with overrides (checked by check_reward_overrides where
        they were read) applied on top; a key of neither file nor schema is an unknown key."""
        root = read_yaml(path if path is not None else default_config_path("reward.yaml"))
        for section, values in (overrides or {}).items():
            root.data.setdefault(section, {}).update(values)
        config = _from_section(root, thresholds)
        root.check_all_used()
        return config


def check_reward_overrides(value: Any, where: str) -> Dict[str, Dict[str, float]]:
    """{section: {key: number}} with the sections and keys of config/reward.yaml, as a scenario's
    <reward> or the training settings give them; ConfigError "<where>: <section>.<key>: <problem>"."""
    if not isinstance(value, dict):
        raise ConfigError(f"{where}: expected a mapping of reward sections, got {value!r}")
    checked: Dict[str, Dict[str, float]] = {}
    for section, values in value.items():
        if section not in REWARD_SCHEMA:
            raise ConfigError(f"{where}: {section}: unknown reward section (known: {', '.join(REWARD_SCHEMA)})")
        if not isinstance(values, dict):
            raise ConfigError(f"{where}: {section}: expected a mapping of keys to numbers, got {values!r}")
        checked[section] = {}
        for key, number in values.items():
            if key not in REWARD_SCHEMA[section]:
                raise ConfigError(f"{where}: {section}.{key}: unknown key (known: {', '.join(REWARD_SCHEMA[section])})")
            if isinstance(number, bool) or not isinstance(number, (int, float)) or not math.isfinite(number):
                raise ConfigError(f"{where}: {section}.{key}: expected a finite number, got {number!r}")
            checked[section][key] = float(number)
    return checked


def merge_reward_overrides(*layers: Mapping[str, Mapping[str, float]]) -> Dict[str, Dict[str, float]]:
    """Overrides one over another, later layers winning key by key (a scenario's <reward>, then
    the training settings')."""
    merged: Dict[str, Dict[str, float]] = {}
    for layer in layers:
        for section, values in layer.items():
            merged.setdefault(section, {}).update(values)
    return merged


def _from_section(root: ConfigSection, thresholds: NavThresholds) -> "RewardConfig":
    weights, logic, nav = root.section("weights"), root.section("logic"), root.section("nav")
    collision, idle = root.section("collision"), root.section("idle")
    return RewardConfig(
        w_logic=weights.number("logic"), w_time=weights.number("time"),
        w_idle=weights.number("idle"), w_col=weights.number("collision"),
        logic_correct_finished=logic.number("correct_finished"),
        logic_correct_unfinished=logic.number("correct_unfinished"),
        logic_wrong_finished=logic.number("wrong_finished"),
        logic_wrong_unfinished=logic.number("wrong_unfinished"),
        logic_no_task=logic.number("no_task"),
        nav_best=nav.number("best"), nav_slope=nav.number("slope"),
        nav_at_or_below_min=nav.number("at_or_below_min"),
        nav_at_or_over_max=nav.number("at_or_over_max"), nav_no_task=nav.number("no_task"),
        col_per_event=collision.number("per_event"),
        idle_per_second=idle.number("per_second"),
        thresholds=thresholds,
    )


def logic_reward(config: RewardConfig, has_task: bool, correct_order: bool, finished: bool) -> float:
    """r_logic: the four cases of SPEC for a task action, `no_task` for None."""
    if not has_task:
        return config.logic_no_task
    if correct_order:
        return config.logic_correct_finished if finished else config.logic_correct_unfinished
    return config.logic_wrong_finished if finished else config.logic_wrong_unfinished


def nav_reward(config: RewardConfig, has_task: bool, nav_time: float) -> float:
    """r_nav on the time the robot navigated this step (reached or not).

    SPEC gives 2 − 2·(t − t_min)/t_avg inside (t_min, t_max) and −8 from t_max on. It gives
    nothing at or below t_min, which no trip between two places of the scenario takes (t_min is
    its shortest leg): only a "trip" to where the robot already stands is that short, and
    rewarding it would pay for standing still in many tiny steps. Default there: 0.
    """
    if not has_task:
        return config.nav_no_task
    th = config.thresholds
    if nav_time >= th.t_max:
        return config.nav_at_or_over_max
    if nav_time <= th.t_min:
        return config.nav_at_or_below_min
    return config.nav_best - config.nav_slope * (nav_time - th.t_min) / th.t_avg


def collision_reward(config: RewardConfig, events: int) -> float:
    """r_col: a fixed value per collision event of this robot in the step."""
    return config.col_per_event * events


def idle_reward(config: RewardConfig, idle_time: float) -> float:
    """r_idle: proportional to the time the robot waited for the step to end."""
    return config.idle_per_second * idle_time


@dataclass(**STEP_RECORD)
class RewardBreakdown:
    """Per-robot unweighted components (names as env.api.REWARD_COMPONENTS) and weighted totals."""

    logic: List[float]
    nav: List[float]
    collision: List[float]
    idle: List[float]
    total: List[float]


def step_rewards(config: RewardConfig, has_task: Sequence[bool], correct_order: Sequence[bool],
                 finished: Sequence[bool], nav_time: Sequence[float], collisions: Sequence[int],
                 idle_time: Sequence[float]) -> RewardBreakdown:
    """Rewards of every robot for one decision step."""
    # One pass filling all five lists: this runs every step of every episode.
    logic: List[float] = []
    nav: List[float] = []
    collision: List[float] = []
    idle: List[float] = []
    total: List[float] = []
    w_logic, w_time, w_col, w_idle = config.w_logic, config.w_time, config.w_col, config.w_idle
    for i, has in enumerate(has_task):
        r_logic = logic_reward(config, has, correct_order[i], finished[i])
        r_nav = nav_reward(config, has, nav_time[i])
        r_col = collision_reward(config, collisions[i])
        r_idle = idle_reward(config, idle_time[i])
        logic.append(r_logic)
        nav.append(r_nav)
        collision.append(r_col)
        idle.append(r_idle)
        total.append(w_logic * r_logic + w_time * r_nav + w_col * r_col + w_idle * r_idle)
    return RewardBreakdown(logic, nav, collision, idle, total)


def event_rewards(config: RewardConfig, ended: Sequence[bool], finished: Sequence[bool], nav_time: Sequence[float],
                  collisions: Sequence[int], waited: Sequence[float]) -> RewardBreakdown:
    """Rewards of every robot for one transition of event mode (env/event_env.py): r_idle for the
    time it waited in it (idle, or at a task for its predecessors), r_col for its collision events,
    and where its attempt at a task ended (finished, failed or wasted) r_logic and r_nav of that
    attempt (in order always: robots wait for predecessors). A None decision earns its waiting."""
    logic: List[float] = []
    nav: List[float] = []
    collision: List[float] = []
    idle: List[float] = []
    total: List[float] = []
    w_logic, w_time, w_col, w_idle = config.w_logic, config.w_time, config.w_col, config.w_idle
    for i, attempt in enumerate(ended):
        r_logic = logic_reward(config, True, True, finished[i]) if attempt else 0.0
        r_nav = nav_reward(config, True, nav_time[i]) if attempt else 0.0
        r_col = collision_reward(config, collisions[i])
        r_idle = idle_reward(config, waited[i])
        logic.append(r_logic)
        nav.append(r_nav)
        collision.append(r_col)
        idle.append(r_idle)
        total.append(w_logic * r_logic + w_time * r_nav + w_col * r_col + w_idle * r_idle)
    return RewardBreakdown(logic, nav, collision, idle, total)
