"""The noise profiles, described once (config/noise_profiles.yaml): how a simulated Burger differs
from the ideal model. The simulator reads the same file (~noise_profiles); the embedded
executor draws its legs from the same figures.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Optional, Tuple, Union

from marl_mrta.common.config import ConfigError, ConfigSection, read_yaml
from marl_mrta.common.paths import default_config_path

DEFAULT_NOISE_FILE = "noise_profiles.yaml"
IDEAL = "ideal"


@dataclass(frozen=True)
class NoiseProfile:
    """Every field at its ideal value by default (the `ideal` profile)."""

    linear_speed_scale: float = 1.0                  # achieved / commanded linear velocity
    command_latency: Tuple[float, float] = (0.0, 0.0)   # s, drawn per command (simulator)
    pause_rate: float = 0.0                          # pauses per second of driving
    pause_duration: Tuple[float, float] = (0.0, 0.0)    # s, each pause
    lidar_range_stddev: float = 0.0                  # m (simulator)
    lidar_dropout: Tuple[float, float] = (0.0, 0.0)  # probability per reading, drawn per scan (simulator)
    odom_translation_stddev: float = 0.0             # relative (simulator)
    odom_rotation_stddev: float = 0.0                # relative (simulator)
    path_stretch_sd: float = 0.0                     # embedded: path length × (1 + |N(0, sd)|)
    proximity_collisions: bool = False               # embedded: robots whose footprints meet on their paths

    @property
    def moves_as_planned(self) -> bool:
        """The embedded executor's legs take exactly their nominal times (nothing is drawn)."""
        return self.linear_speed_scale == 1.0 and self.path_stretch_sd == 0.0 and self.pause_rate == 0.0


def _interval(section: ConfigSection, key: str, low: float, high: Optional[float]) -> Tuple[float, float]:
    value = section.raw(key, None)
    if value is None:
        return (0.0, 0.0)
    if not isinstance(value, list) or len(value) != 2 or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise section.fail(key, f"expected [min, max], got {value!r}")
    lo, hi = float(value[0]), float(value[1])
    if not low <= lo <= hi or (high is not None and hi > high):
        bound = f" <= {high}" if high is not None else ""
        raise section.fail(key, f"need {low} <= min <= max{bound}, got {value!r}")
    return lo, hi


def _profile(section: ConfigSection) -> NoiseProfile:
    ideal = NoiseProfile()
    return NoiseProfile(
        linear_speed_scale=section.number("linear_speed_scale", ideal.linear_speed_scale, above=0.0, maximum=1.0),
        command_latency=_interval(section, "command_latency", 0.0, None),
        pause_rate=section.number("pause_rate", ideal.pause_rate, minimum=0.0),
        pause_duration=_interval(section, "pause_duration", 0.0, None),
        lidar_range_stddev=section.number("lidar_range_stddev", ideal.lidar_range_stddev, minimum=0.0),
        lidar_dropout=_interval(section, "lidar_dropout", 0.0, 1.0),
        odom_translation_stddev=section.number("odom_translation_stddev", ideal.odom_translation_stddev, minimum=0.0),
        odom_rotation_stddev=section.number("odom_rotation_stddev", ideal.odom_rotation_stddev, minimum=0.0),
        path_stretch_sd=section.number("path_stretch_sd", ideal.path_stretch_sd, minimum=0.0),
        proximity_collisions=section.boolean("proximity_collisions", ideal.proximity_collisions),
    )


def load_noise_profiles(path: Optional[Union[str, Path]] = None) -> Dict[str, NoiseProfile]:
    """Every profile of config/noise_profiles.yaml (or `path`), each checked key by key."""
    root = read_yaml(path if path is not None else default_config_path(DEFAULT_NOISE_FILE))
    profiles = {str(name): _profile(root.section(name)) for name in root.keys()}
    root.check_all_used()
    if IDEAL not in profiles:
        raise ConfigError(f"{root.source}: {IDEAL}: missing profile (the one without noise)")
    return profiles
