"""The robot, described once (config/robot_burger.yaml): body, drive limits, lidar.

The simulator loads the same file into its private namespace; the embedded executor's travel
model, the scenario checks (footprints that overlap) and the checks of the navigation
parameter files read it here.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Tuple, Union

from marl_mrta.common.config import read_yaml
from marl_mrta.common.paths import default_config_path

DEFAULT_ROBOT_FILE = "robot_burger.yaml"


@dataclass(frozen=True)
class RobotDescription:
    footprint: Tuple[Tuple[float, float], ...]   # m, polygon in base_footprint (navigation's costmaps)
    radius: float                                # m, the circle the simulator collides with
    wheel_radius: float                          # m
    wheel_separation: float                      # m
    max_linear_velocity: float                   # m/s
    max_angular_velocity: float                  # rad/s
    max_linear_acceleration: float               # m/s^2
    max_angular_acceleration: float              # rad/s^2
    lidar_beams: int
    lidar_range_min: float                       # m
    lidar_range_max: float                       # m
    lidar_offset: Tuple[float, float, float]     # m, base_scan in base_footprint
    scan_rate: float                             # Hz


def load_robot(path: Optional[Union[str, Path]] = None) -> RobotDescription:
    """config/robot_burger.yaml (or `path`), every key read and checked."""
    root = read_yaml(path if path is not None else default_config_path(DEFAULT_ROBOT_FILE))
    corners = root.raw("footprint")
    if not isinstance(corners, list) or len(corners) < 3 or not all(
            isinstance(c, list) and len(c) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in c)
            for c in corners):
        raise root.fail("footprint", f"expected a list of at least 3 [x, y] points, got {corners!r}")
    robot = RobotDescription(
        footprint=tuple((float(x), float(y)) for x, y in corners),
        radius=root.number("robot_radius", above=0.0),
        wheel_radius=root.number("wheel_radius", above=0.0),
        wheel_separation=root.number("wheel_separation", above=0.0),
        max_linear_velocity=root.number("max_linear_velocity", above=0.0),
        max_angular_velocity=root.number("max_angular_velocity", above=0.0),
        max_linear_acceleration=root.number("max_linear_acceleration", above=0.0),
        max_angular_acceleration=root.number("max_angular_acceleration", above=0.0),
        lidar_beams=root.integer("lidar_beams", minimum=1),
        lidar_range_min=root.number("lidar_range_min", minimum=0.0),
        lidar_range_max=root.number("lidar_range_max", above=0.0),
        lidar_offset=(root.number("lidar_offset_x"), root.number("lidar_offset_y"), root.number("lidar_offset_z")),
        scan_rate=root.number("scan_rate", minimum=0.0),
    )
    root.check_all_used()
    return robot
