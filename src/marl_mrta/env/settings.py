"""Settings of the decision process (config/task.yaml) and of the embedded executor
(config/task_embedded.yaml), read strictly (unknown keys are errors)."""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Dict, Optional, Union

from marl_mrta.common.config import ConfigError, read_yaml
from marl_mrta.common.paths import default_config_path
from marl_mrta.model.goal_timeout import GoalTimeout, TimeoutValue, parse_timeout
from marl_mrta.model.noise import NoiseProfile, load_noise_profiles
from marl_mrta.model.robot import load_robot
from marl_mrta.model.travel import TravelModel

if TYPE_CHECKING:
    from marl_mrta.model.scenario import Scenario

MASK_MODES = ("none", "finished", "logic")
DECISION_MODES = ("synchronous", "event")


@dataclass(frozen=True)
class TaskSettings:
    mask: str            # none | finished | logic
    min_step: float      # s, shortest step (the whole step when every robot chose None)
    goal_timeout: GoalTimeout   # per leg: fixed seconds, or auto (model/goal_timeout.py)
    hold_successors: bool = False   # a robot early at a successor waits for its predecessors (model/rules.py)
    # s a successor must be reached after its predecessor's finish in one step to count as in
    # order (model/rules.py's order_margin); not in task.yaml: a model that plans with a margin sets it
    precedence_margin: float = 0.0
    decision_mode: str = "synchronous"   # synchronous | event (env/task_env.py, env/event_env.py)
    # <episode timeout="auto">: this × the sum over tasks of (shortest leg in + service), env/factory.py
    episode_timeout_factor: float = 3.0

    def for_scenario(self, scenario: "Scenario", goal_timeout: Optional[TimeoutValue] = None) -> "TaskSettings":
        """These settings with the scenario's own goal timeout (<episode goal_timeout>) over the
        file's, and `goal_timeout` (a command line's or a launch file's: seconds or 'auto') over both."""
        rule = self.goal_timeout.with_value(scenario.goal_timeout).with_value(goal_timeout)
        return self if rule == self.goal_timeout else replace(self, goal_timeout=rule)


def load_task_settings(path: Optional[Union[str, Path]] = None) -> TaskSettings:
    root = read_yaml(path if path is not None else default_config_path("task.yaml"))
    raw = root.raw("goal_timeout")
    try:
        value = parse_timeout(raw)
    except ValueError as problem:
        raise root.fail("goal_timeout", str(problem)) from None
    rule = GoalTimeout(seconds=None if isinstance(value, str) else value,
                       factor=root.number("goal_timeout_factor", minimum=1.0),
                       margin=root.number("goal_timeout_margin", minimum=0.0))
    settings = TaskSettings(mask=root.choice("mask", list(MASK_MODES)),
                            min_step=root.number("min_step", minimum=1e-3),
                            goal_timeout=rule,
                            hold_successors=root.boolean("hold_successors", False),
                            decision_mode=root.choice("decision_mode", list(DECISION_MODES)),
                            episode_timeout_factor=root.number("episode_timeout_factor", minimum=1.0))
    root.check_all_used()
    return settings


@dataclass(frozen=True)
class EmbeddedSettings:
    travel: TravelModel
    default_profile: str
    profiles: Dict[str, NoiseProfile]   # config/noise_profiles.yaml, the simulator's too
    collision_distance: float           # m between robot centres: two footprints' radii
    collision_dt: float                 # s, time resolution of the proximity check

    def profile(self, name: Optional[str] = None) -> NoiseProfile:
        name = name or self.default_profile
        if name not in self.profiles:
            raise ConfigError(f"embedded executor: unknown noise profile {name!r} (known: {', '.join(self.profiles)})")
        return self.profiles[name]


def load_embedded_settings(path: Optional[Union[str, Path]] = None, noise_path: Optional[Union[str, Path]] = None,
                           robot_path: Optional[Union[str, Path]] = None,
                           nav_config_dir: Optional[Union[str, Path]] = None) -> EmbeddedSettings:
    """config/task_embedded.yaml with the robot (config/robot_burger.yaml), the noise profiles
    (config/noise_profiles.yaml) and the navigation's parameter files (config/nav/, the files
    robot_nav.launch loads) on which the travel paths are planned."""
    root = read_yaml(path if path is not None else default_config_path("task_embedded.yaml"))
    robot = load_robot(robot_path)
    travel = root.section("travel")
    model = TravelModel(
        nav_config_dir=str(Path(nav_config_dir if nav_config_dir is not None else default_config_path("nav")).resolve()),
        linear_speed=robot.max_linear_velocity,
        angular_speed=travel.number("angular_speed", above=0.0),
        min_goal_time=travel.number("min_goal_time", above=0.0),
        heading_lookahead=travel.number("heading_lookahead", above=0.0),
    )
    profiles = load_noise_profiles(noise_path)
    default = root.choice("profile", list(profiles))
    collision_dt = root.number("collision_dt", above=0.0)
    root.check_all_used()
    return EmbeddedSettings(model, default, profiles, 2.0 * robot.radius, collision_dt)
