"""Settings of the decision process (config/task.yaml) and of the embedded executor
(config/task_embedded.yaml), read strictly (unknown keys are errors)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Optional, Union

from marl_mrta.common.config import ConfigError, read_yaml
from marl_mrta.common.paths import default_config_path
from marl_mrta.model.travel import TravelModel
from marl_mrta.env.embedded import NoiseProfile

MASK_MODES = ("none", "finished", "logic")


@dataclass(frozen=True)
class TaskSettings:
    mask: str            # none | finished | logic
    min_step: float      # s, shortest step (the whole step when every robot chose None)
    goal_timeout: float  # s, per goal


def load_task_settings(path: Optional[Union[str, Path]] = None) -> TaskSettings:
    root = read_yaml(path if path is not None else default_config_path("task.yaml"))
    settings = TaskSettings(mask=root.choice("mask", list(MASK_MODES)),
                            min_step=root.number("min_step", minimum=1e-3),
                            goal_timeout=root.number("goal_timeout", minimum=1e-3))
    root.check_all_used()
    return settings


@dataclass(frozen=True)
class EmbeddedSettings:
    travel: TravelModel
    default_profile: str
    profiles: Dict[str, NoiseProfile]

    def profile(self, name: Optional[str] = None) -> NoiseProfile:
        name = name or self.default_profile
        if name not in self.profiles:
            raise ConfigError(f"embedded executor: unknown noise profile {name!r} (known: {', '.join(self.profiles)})")
        return self.profiles[name]


def load_embedded_settings(path: Optional[Union[str, Path]] = None) -> EmbeddedSettings:
    root = read_yaml(path if path is not None else default_config_path("task_embedded.yaml"))
    travel = root.section("travel")
    model = TravelModel(
        inscribed_radius=travel.number("inscribed_radius", minimum=0.0),
        inflation_radius=travel.number("inflation_radius", minimum=0.0),
        cost_scaling_factor=travel.number("cost_scaling_factor", minimum=0.0),
        neutral_cost=travel.number("neutral_cost", minimum=1.0),
        cost_factor=travel.number("cost_factor", minimum=0.0),
        linear_speed=travel.number("linear_speed", minimum=1e-3),
        angular_speed=travel.number("angular_speed", minimum=1e-3),
        min_goal_time=travel.number("min_goal_time", minimum=1e-3),
    )
    profiles_section = root.section("profiles")
    profiles = {name: NoiseProfile.from_section(profiles_section.section(name)) for name in profiles_section.keys()}
    if not profiles:
        raise ConfigError(f"{root.source}: profiles: at least one profile is needed")
    default = root.choice("profile", list(profiles))
    root.check_all_used()
    return EmbeddedSettings(model, default, profiles)
