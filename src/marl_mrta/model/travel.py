"""Nominal travel times between a scenario's poses, on navigation's own plans.

1. The paths: navfn's, planned on move_base's global costmap (static + inflation layers) from
   the scenario's map file and the navigation's parameter files (config/nav/), by the C++ core
   that move_base runs (model/navfn_paths.py).
2. time = initial turn / ω + length / v + final turn / ω (turning in place, as DWA does when
   the heading is far off), v the Burger's top speed (config/robot_burger.yaml) or, where the
   navigation's files set DWA's max_vel_x (or max_vel_trans) lower, that speed, ω the turning
   speed the navigation achieves (config/task_embedded.yaml), at least `min_goal_time` (a goal at
   the robot's pose still costs a control cycle). The turns are to and from the path's direction
   over its first and last `heading_lookahead` metres: the direction DWA turns to before it drives;
   the first segment alone runs to a cell's corner and its direction is a cell's noise.

Nodes: the robots' start poses first (node r = robot r), then the task goals (node n_robots + j).
Tables are cached per (map and navigation file states, poses, parameters) so environments
built on the same scenario share one computation.
"""
from __future__ import annotations

import math
import os
from dataclasses import astuple, dataclass, replace
from functools import cached_property
from typing import Dict, List, Sequence, Tuple

import numpy as np

from marl_mrta.common.config import ConfigError
from marl_mrta.common.yaml_file import YamlFileError, load_yaml_file
from marl_mrta.model.navfn_paths import PlanningError, plan_all_pairs
from marl_mrta.model.scenario import Scenario, ScenarioError


@dataclass(frozen=True)
class TravelModel:
    """Parameters of the travel-time model, each read from the file that owns it
    (env/settings.py: the robot file, the navigation's directory, config/task_embedded.yaml)."""

    nav_config_dir: str                  # the navigation's parameter files (config/nav)
    linear_speed: float                  # m/s, the robot's top speed (config/robot_burger.yaml); in a
                                         # table, at most the local planner's (the navigation files)
    angular_speed: float                 # rad/s, effective turning in place (config/task_embedded.yaml)
    min_goal_time: float                 # s (config/task_embedded.yaml)
    heading_lookahead: float             # m of path over which a turn's heading is taken (the same file)


@dataclass
class TravelTable:
    """Pairwise nominal travel between nodes (robot starts, then task goals)."""

    node_poses: List[Tuple[float, float, float]]
    length: np.ndarray           # (n, n) m, path length
    turn_time: np.ndarray        # (n, n) s, initial + final turn in place
    nominal_time: np.ndarray     # (n, n) s
    paths: List[List[np.ndarray]]   # paths[a][b]: (k, 2) polyline a -> b in the map frame
    model: TravelModel

    def __post_init__(self) -> None:
        # Plain lists: the executor reads single entries thousands of times per second.
        self.length_rows = self.length.tolist()
        self.turn_rows = self.turn_time.tolist()
        self.time_rows = self.nominal_time.tolist()

    @cached_property
    def path_along(self) -> List[List[np.ndarray]]:
        """Distance along each path at its points, for placing robots on it (the proximity check):
        navfn's paths have a point per cell, too many to measure again at every step; measured on
        first use, so tables of runs without the check never are."""
        return [[np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))]) for path in row]
                for row in self.paths]

    @property
    def n_nodes(self) -> int:
        return len(self.node_poses)


def _angle_diff(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


def path_heading(points: np.ndarray, lookahead: float) -> float:
    """Direction [rad] from the path's first point to its point `lookahead` metres along it
    (or its last point, on a shorter path)."""
    travelled = np.cumsum(np.hypot(*np.diff(points, axis=0).T))
    ahead = int(np.searchsorted(travelled, lookahead)) + 1
    dx, dy = points[min(ahead, len(points) - 1)] - points[0]
    return math.atan2(dy, dx)


def build_travel_table(map_path: str, poses: Sequence[Tuple[float, float, float]], model: TravelModel) -> TravelTable:
    """Navigation's plan between every pair of poses; PlanningError naming the pose it cannot plan."""
    navfn, planner_speed = plan_all_pairs(map_path, model.nav_config_dir, poses)
    # Robots drive no faster than their local planner lets them (DWA's max_vel_x, which a lab
    # may set below the robot's top speed).
    model = replace(model, linear_speed=min(model.linear_speed, planner_speed))
    n = len(poses)
    length = np.zeros((n, n))
    turn = np.zeros((n, n))
    paths: List[List[np.ndarray]] = [[np.zeros((0, 2))] * n for _ in range(n)]
    for a in range(n):
        for b in range(n):
            xa, ya, yaw_a = poses[a]
            xb, yb, yaw_b = poses[b]
            points = navfn[a][b]
            if points is None:
                points = np.array([(xa, ya), (xb, yb)], dtype=np.float64)
            else:
                # The robot leaves from its own pose, not its cell's corner, and ends at the goal.
                points[0] = (xa, ya)
                if math.hypot(points[-1, 0] - xb, points[-1, 1] - yb) > 1e-9:
                    points = np.vstack([points, [(xb, yb)]])
            length[a, b] = float(np.hypot(*np.diff(points, axis=0).T).sum())
            if length[a, b] > 1e-9:
                heading_in = path_heading(points, model.heading_lookahead)
                heading_out = path_heading(points[::-1], model.heading_lookahead) + math.pi
                turn[a, b] = (_angle_diff(heading_in, yaw_a) + _angle_diff(yaw_b, heading_out)) / model.angular_speed
            else:
                turn[a, b] = _angle_diff(yaw_b, yaw_a) / model.angular_speed
            paths[a][b] = points
    nominal = np.maximum(turn + length / model.linear_speed, model.min_goal_time)
    return TravelTable(list(poses), length, turn, nominal, paths, model)


_CACHE: Dict[tuple, TravelTable] = {}


def _file_states(map_path: str, nav_config_dir: str) -> tuple:
    """What the table is planned from, as file states: the map's YAML and image and the
    navigation's parameter files, so that an edited file (a track_unknown_space set, an image
    saved again) is planned anew."""
    paths = [map_path]
    try:
        image = load_yaml_file(map_path).get("image")
        if isinstance(image, str) and image:
            paths.append(os.path.join(os.path.dirname(map_path), image))
    except (YamlFileError, AttributeError):
        pass   # the planner reports a bad map file
    if os.path.isdir(nav_config_dir):
        paths += sorted(os.path.join(nav_config_dir, name) for name in os.listdir(nav_config_dir))
    states = []
    for path in paths:
        try:
            stat = os.stat(path)
            states.append((os.path.realpath(path), stat.st_mtime_ns, stat.st_size))
        except OSError:
            states.append((path, None, None))
    return tuple(states)


def cached_travel_table(map_path: str, poses: Sequence[Tuple[float, float, float]], model: TravelModel) -> TravelTable:
    """build_travel_table, computed once per (map and navigation file states, poses, model) in this
    process."""
    os.stat(map_path)   # a missing map file is an OSError here, as before
    key = (os.path.realpath(map_path), _file_states(map_path, model.nav_config_dir),
           tuple(tuple(float(v) for v in pose) for pose in poses), astuple(model))
    table = _CACHE.get(key)
    if table is None:
        table = build_travel_table(key[0], poses, model)
        _CACHE[key] = table
    return table


def suggest_nav_thresholds(table: TravelTable, n_robots: int) -> Tuple[float, float, float]:
    """t_min, t_avg, t_max for a scenario from its nominal legs (start -> task, task -> task):
    t_min = shortest leg, t_avg = mean leg, t_max = 1.5 × longest leg (docs/guide/evaluation.md)."""
    n = table.n_nodes
    legs = [table.nominal_time[a, b] for a in range(n) for b in range(n_robots, n) if a != b]
    return (math.floor(min(legs) * 2.0) / 2.0, round(float(np.mean(legs)), 1),
            math.ceil(1.5 * max(legs) * 2.0) / 2.0)


def scenario_poses(scenario: Scenario) -> List[Tuple[float, float, float]]:
    """The node poses of a scenario: robots' starts, then task goals."""
    return ([(r.start.x, r.start.y, r.start.yaw) for r in scenario.robots]
            + [(t.goal.x, t.goal.y, t.goal.yaw) for t in scenario.tasks])


def scenario_travel_model(scenario: Scenario, model: TravelModel) -> TravelModel:
    """The travel model with the scenario's robots' navigation files when it names them (<robots navigation>)."""
    if scenario.navigation_dir is not None:
        return replace(model, nav_config_dir=str(scenario.navigation_dir))
    return model


def nominal_travel_table(scenario: Scenario, model: TravelModel) -> TravelTable:
    """The cached table of a scenario, planned with its robots' navigation files when it names
    them (<robots navigation>); ScenarioError naming the robot or task navigation cannot plan
    from or to, ConfigError for a bad navigation parameter file."""
    model = scenario_travel_model(scenario, model)
    try:
        return cached_travel_table(str(scenario.map_path), scenario_poses(scenario), model)
    except PlanningError as error:
        if error.pose < 0:
            raise ConfigError(f"travel planning on {scenario.map_path} with the navigation files of "
                              f"{model.nav_config_dir}: {error}") from None
        if error.pose < scenario.n_robots:
            robot = scenario.robots[error.pose]
            element, what, (x, y) = f"<robot id=\"{robot.id}\">", "start pose", (robot.start.x, robot.start.y)
        else:
            task = scenario.tasks[error.pose - scenario.n_robots]
            element, what, (x, y) = f"<task id=\"{task.id}\">", "goal", (task.goal.x, task.goal.y)
        # The library names the pose by its index; the scenario names it by its element.
        problem = str(error).split(": ", 1)[-1]
        raise ScenarioError(f"{scenario.source}: {element}: {what} ({x:g}, {y:g}): {problem}") from None
