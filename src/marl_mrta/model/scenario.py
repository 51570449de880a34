"""Scenario files (the paper's scheduler XML): robots, tasks, precedence, timing, reward overrides.

The format is documented in docs/reference/scenario_format.md. `load_scenario(path)`
validates everything it reads and raises ScenarioError whose text is one line naming the file,
the element and the problem; command-line tools print it and exit non-zero. Beyond the format:
robots whose start footprints overlap, task goals closer than a robot's footprint, a task that
cannot be finished within the episode timeout (its own service time, or the service times of
the precedence chain before it), and precedence cycles are refused. What needs the travel times
(a goal navigation cannot reach) is checked where they are computed (model/travel.py,
baselines/reference.py). `<episode timeout>` and its optional `goal_timeout` may be `auto`
(model/goal_timeout.py): an auto episode timeout is computed from the travel table when the
environment is built (env/factory.py), long enough for every chain of service times.
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

from marl_mrta.model.goal_timeout import AUTO, TimeoutValue, parse_timeout
from marl_mrta.model.occupancy_map import FREE, OCCUPIED, MapFileError, OccupancyMap, load_map, load_navigation_map
from marl_mrta.common.paths import resolve_resource
from marl_mrta.common.config import ConfigError
from marl_mrta.model.reward import NavThresholds, check_reward_overrides
from marl_mrta.model.robot import load_robot


def footprint_radius() -> float:
    """m, the radius of the robot's footprint circle (config/robot_burger.yaml `robot_radius`)."""
    return load_robot().radius


def footprint_spacing() -> float:
    """m, the least distance between two robots' centres, or between a robot and the goal another
    robot is sent to: closer, their footprints overlap (two footprint radii)."""
    return 2.0 * footprint_radius()


class ScenarioError(ValueError):
    """An invalid scenario file; str(error) is one line: file, element, problem."""


@dataclass(frozen=True)
class Pose2D:
    x: float
    y: float
    yaw: float   # rad, REP 103 (counter-clockwise from the map's x axis)


@dataclass(frozen=True)
class RobotSpec:
    id: str          # also the robot's ROS namespace
    start: Pose2D


@dataclass(frozen=True)
class TaskSpec:
    id: str
    category: str
    goal: Pose2D
    service_time: float   # s spent at the goal after arrival (pick/place), default 0
    # s since the episode's start at which the task becomes known (a live fleet: unknown to every
    # method before it); 0: known from the start
    release: float = 0.0


@dataclass(frozen=True)
class FaultSpec:
    """<faults>/<fault>: robot (index) leaves the fleet `at` s after the episode's start."""

    robot: int
    at: float


@dataclass(frozen=True)
class Scenario:
    name: str
    source: Path
    map_path: Path
    robots: Tuple[RobotSpec, ...]
    tasks: Tuple[TaskSpec, ...]
    predecessors: Tuple[Tuple[int, ...], ...]   # per task index: indices that must come first
    nav_thresholds: Optional[NavThresholds]   # None only from load_scenario(nav_time_required=False)
    # s; None: <episode timeout="auto">, computed from the travel table when the environment is
    # built (env/factory.py make_env: its env.scenario always has a number)
    episode_timeout: Optional[float]
    map_bounds: Tuple[float, float, float, float]   # x, y of the map's lower-left corner, width, height (m)
    reward_overrides: Dict[str, Dict[str, float]] = field(default_factory=dict)
    # The robots' navigation parameter files (the directory robot_nav.launch loads them from), when
    # the scenario names one (<robots navigation="...">), as an absolute path; None: the package's
    # config/nav.
    navigation_dir: Optional[Path] = None
    # <episode goal_timeout>: seconds or "auto" (model/goal_timeout.py), over config/task.yaml's;
    # None: not given. make_env's env.scenario carries the goal timeout its episodes run with.
    goal_timeout: Optional[TimeoutValue] = None
    # <faults>: robots that leave the fleet during the episode, by time
    faults: Tuple[FaultSpec, ...] = ()

    @property
    def live(self) -> bool:
        """Tasks released after the start, or robots that leave: the fleet changes while it works."""
        return bool(self.faults) or any(task.release > 0.0 for task in self.tasks)

    @property
    def n_robots(self) -> int:
        return len(self.robots)

    @property
    def n_tasks(self) -> int:
        return len(self.tasks)

    @property
    def categories(self) -> Tuple[str, ...]:
        """Task categories in sorted order (the observation's one-hot order)."""
        return tuple(sorted({task.category for task in self.tasks}))

    def task_index(self, task_id: str) -> int:
        for index, task in enumerate(self.tasks):
            if task.id == task_id:
                return index
        raise KeyError(task_id)

    def load_map(self) -> OccupancyMap:
        return load_map(self.map_path)


_ROOT_CHILDREN = ("map", "robots", "tasks", "precedence", "episode", "nav_time", "reward", "faults")


class _Reader:
    """Validating reader of one scenario file; every problem becomes a one-line ScenarioError."""

    def __init__(self, path: Path):
        self.path = path

    def fail(self, element: Optional[ET.Element], problem: str) -> ScenarioError:
        where = _describe(element) if element is not None else "file"
        return ScenarioError(f"{self.path}: {where}: {problem}")

    def attributes(self, element: ET.Element, required: Sequence[str], optional: Sequence[str] = ()) -> None:
        for name in element.attrib:
            if name not in required and name not in optional:
                raise self.fail(element, f"unknown attribute '{name}'")
        for name in required:
            if name not in element.attrib:
                raise self.fail(element, f"missing attribute '{name}'")

    def resource(self, element: ET.Element, name: str) -> Path:
        """A file or directory the attribute names (package://, absolute, or relative to the scenario)."""
        try:
            return resolve_resource(self.text(element, name), self.path.parent)
        except ValueError as error:
            raise self.fail(element, f"{name}: {error}") from None

    def text(self, element: ET.Element, name: str) -> str:
        value = element.attrib[name].strip()
        if not value:
            raise self.fail(element, f"attribute '{name}' is empty")
        return value

    def number(self, element: ET.Element, name: str, default: Optional[float] = None) -> float:
        if name not in element.attrib and default is not None:
            return default
        raw = element.attrib[name]
        try:
            value = float(raw)
        except ValueError:
            raise self.fail(element, f"attribute '{name}' is not a number: {raw!r}") from None
        if not math.isfinite(value):
            raise self.fail(element, f"attribute '{name}' is not finite: {raw!r}")
        return value

    def timeout(self, element: ET.Element, name: str) -> TimeoutValue:
        """A timeout attribute: a positive number of seconds, or auto."""
        raw = self.text(element, name)
        try:
            return parse_timeout(raw)
        except ValueError as problem:
            raise self.fail(element, f"{name} {problem}") from None

    def single(self, root: ET.Element, tag: str, required: bool = True) -> Optional[ET.Element]:
        found = root.findall(tag)
        if len(found) > 1:
            raise self.fail(found[1], f"<{tag}> given more than once")
        if not found:
            if required:
                raise self.fail(root, f"missing element <{tag}>")
            return None
        return found[0]

    def children(self, parent: ET.Element, tag: str) -> List[ET.Element]:
        for child in parent:
            if child.tag != tag:
                raise self.fail(child, f"unexpected element inside <{parent.tag}> (expected <{tag}>)")
        return list(parent)

    def pose(self, element: ET.Element) -> Pose2D:
        return Pose2D(self.number(element, "x"), self.number(element, "y"), self.number(element, "yaw"))

    def check_on_free_cell(self, element: ET.Element, grid_map: OccupancyMap, pose: Pose2D, what: str) -> None:
        problem = free_cell_problem(grid_map, pose, what)
        if problem:
            raise self.fail(element, problem)


def free_cell_problem(grid_map: OccupancyMap, pose: Pose2D, what: str) -> str:
    """Why `pose` cannot be a start pose or goal (off the map, inside an obstacle, on an unknown
    cell), one phrase; "" when it stands on a free cell. Scenario files and tasks submitted to a
    live fleet (env/live_fleet.py) alike."""
    cell = grid_map.world_to_cell(pose.x, pose.y)
    if cell is None:
        return f"{what} ({pose.x:g}, {pose.y:g}) is off the map"
    value = int(grid_map.grid[cell.row, cell.col])
    if value == OCCUPIED:
        return f"{what} ({pose.x:g}, {pose.y:g}) is inside an obstacle"
    if value != FREE:
        return f"{what} ({pose.x:g}, {pose.y:g}) is on an unknown (not free) cell"
    return ""


def _describe(element: ET.Element) -> str:
    key = element.attrib.get("id")
    if key is None and element.tag == "edge":
        return f"<edge before=\"{element.attrib.get('before', '')}\" after=\"{element.attrib.get('after', '')}\">"
    if key is None and element.tag == "fault":
        return f"<fault robot=\"{element.attrib.get('robot', '')}\">"
    return f"<{element.tag} id=\"{key}\">" if key is not None else f"<{element.tag}>"


def load_scenario(path: Union[str, Path], nav_time_required: bool = True) -> Scenario:
    """Read and validate a scenario file. nav_time_required=False: a file without <nav_time> loads
    with nav_thresholds None (travel_table, which suggests them, reads such a file)."""
    path = Path(path)
    reader = _Reader(path)
    try:
        root = ET.parse(str(path)).getroot()
    except OSError as error:
        raise ScenarioError(f"{path}: file: cannot read ({error.strerror})") from None
    except ET.ParseError as error:
        raise ScenarioError(f"{path}: file: not well-formed XML ({error})") from None
    if root.tag != "scenario":
        raise reader.fail(root, "the root element must be <scenario>")
    reader.attributes(root, ("name",))
    name = reader.text(root, "name")
    for child in root:
        if child.tag not in _ROOT_CHILDREN:
            raise reader.fail(child, f"unknown element (expected one of {', '.join(_ROOT_CHILDREN)})")

    map_element = reader.single(root, "map")
    reader.attributes(map_element, ("file",))
    map_path = reader.resource(map_element, "file")
    try:
        grid_map = load_navigation_map(map_path)
    except MapFileError as error:
        raise reader.fail(map_element, f"cannot load the map: {error}") from None

    spacing = footprint_spacing()
    robots_element = reader.single(root, "robots")
    reader.attributes(robots_element, (), ("navigation",))
    navigation_dir = None
    if "navigation" in robots_element.attrib:
        navigation_dir = reader.resource(robots_element, "navigation").resolve()
        if not navigation_dir.is_dir():
            raise reader.fail(robots_element, f"navigation: {navigation_dir} is not a directory")
    robots = _read_robots(reader, robots_element, grid_map)
    _check_apart(reader, robots_element, [r.start for r in robots], spacing, "robot", "start pose",
                 "overlaps the footprint of robot", [r.id for r in robots])
    tasks_element = reader.single(root, "tasks")
    tasks = _read_tasks(reader, tasks_element, grid_map)
    _check_apart(reader, tasks_element, [t.goal for t in tasks], spacing, "task", "goal",
                 "is closer than a robot's footprint to the goal of task", [t.id for t in tasks])
    predecessors = _read_precedence(reader, reader.single(root, "precedence", required=False), tasks)

    episode = reader.single(root, "episode")
    reader.attributes(episode, ("timeout",), ("goal_timeout",))
    timeout = reader.timeout(episode, "timeout")
    goal_timeout = reader.timeout(episode, "goal_timeout") if "goal_timeout" in episode.attrib else None
    if timeout == AUTO:
        timeout = None   # long enough for every chain of service times (env/factory.py)
    else:
        _check_chains_fit(reader, tasks_element, tasks, predecessors, timeout)

    thresholds = _read_nav_thresholds(reader, root, nav_time_required)

    overrides = _read_reward_overrides(reader, reader.single(root, "reward", required=False))
    faults = _read_faults(reader, reader.single(root, "faults", required=False), robots)
    return Scenario(name=name, source=path, map_path=map_path, robots=robots, tasks=tasks,
                    predecessors=predecessors, nav_thresholds=thresholds, episode_timeout=timeout,
                    map_bounds=(grid_map.origin.x, grid_map.origin.y, grid_map.width * grid_map.resolution,
                                grid_map.height * grid_map.resolution),
                    reward_overrides=overrides, navigation_dir=navigation_dir, goal_timeout=goal_timeout,
                    faults=faults)


def _read_posed(reader: _Reader, parent: ET.Element, tag: str, attributes: Sequence[str],
                optional: Sequence[str], grid_map: OccupancyMap, what: str) -> List[Tuple[ET.Element, str, Pose2D]]:
    """The <tag> children of `parent`: element, unique id and pose on a free cell, in order."""
    found: List[Tuple[ET.Element, str, Pose2D]] = []
    seen = set()
    for element in reader.children(parent, tag):
        reader.attributes(element, attributes, optional)
        key = reader.text(element, "id")
        if key in seen:
            raise reader.fail(element, f"duplicate {tag} id")
        seen.add(key)
        pose = reader.pose(element)
        reader.check_on_free_cell(element, grid_map, pose, what)
        found.append((element, key, pose))
    if not found:
        raise reader.fail(parent, f"no <{tag}> given")
    return found


def _check_apart(reader: _Reader, parent: ET.Element, poses: Sequence[Pose2D], need: float, tag: str,
                 what: str, problem: str, ids: Sequence[str]) -> None:
    """Poses closer than `need` (footprint_spacing): the later one is named (with the earlier)."""
    elements = [e for e in parent if e.tag == tag]
    for j in range(len(poses)):
        for i in range(j):
            apart = math.hypot(poses[j].x - poses[i].x, poses[j].y - poses[i].y)
            if apart < need:
                raise reader.fail(elements[j], f"{what} ({poses[j].x:g}, {poses[j].y:g}) {problem} {ids[i]} "
                                               f"({apart:.3g} m apart, at least {need:.3g} m needed)")


def _read_nav_thresholds(reader: _Reader, root: ET.Element, required: bool) -> Optional[NavThresholds]:
    nav_element = reader.single(root, "nav_time", required=False)
    if nav_element is None:
        if required:
            raise reader.fail(root, "missing element <nav_time> (the r_nav thresholds t_min, t_avg, t_max; "
                                    f"`rosrun marl_mrta travel_table {reader.path}` suggests them)")
        return None
    reader.attributes(nav_element, ("t_min", "t_avg", "t_max"))
    thresholds = NavThresholds(reader.number(nav_element, "t_min"), reader.number(nav_element, "t_avg"),
                               reader.number(nav_element, "t_max"))
    if not 0.0 <= thresholds.t_min < thresholds.t_max or thresholds.t_avg <= 0.0:
        raise reader.fail(nav_element, "need 0 <= t_min < t_max and t_avg > 0")
    return thresholds


def _check_chains_fit(reader: _Reader, parent: ET.Element, tasks: Sequence["TaskSpec"],
                      predecessors: Sequence[Sequence[int]], timeout: float) -> None:
    """Every task can be finished in order within the episode: its service time, from its release
    and after the service times of the longest precedence chain before it (predecessors finish
    strictly first, one after another), ends by the timeout."""
    elements = [e for e in parent if e.tag == "task"]
    done_by: Dict[int, Tuple[float, List[int]]] = {}

    def earliest(j: int) -> Tuple[float, List[int]]:
        if j not in done_by:
            before, chain = max((earliest(p) for p in predecessors[j]), default=(0.0, []), key=lambda c: c[0])
            done_by[j] = (max(before, tasks[j].release) + tasks[j].service_time, chain + [j])
        return done_by[j]

    for j, task in enumerate(tasks):
        if task.service_time > timeout:
            raise reader.fail(elements[j], f"service_time {task.service_time:g} s does not fit in the episode "
                                           f"timeout ({timeout:g} s)")
    for j in range(len(tasks)):
        finish, chain = earliest(j)
        if finish > timeout:
            path = " -> ".join(tasks[i].id for i in chain)
            what = "release and service" if any(tasks[i].release > 0.0 for i in chain) else "service"
            raise reader.fail(elements[j], f"cannot be finished in order within the episode timeout ({timeout:g} s): "
                                           f"the chain {path} needs {finish:g} s of {what} alone")


#: A relative ROS graph name: what a robot id may be, since it is the robot's namespace.
_NAMESPACE = re.compile(r"[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*")


def _read_robots(reader: _Reader, parent: ET.Element, grid_map: OccupancyMap) -> Tuple[RobotSpec, ...]:
    robots = _read_posed(reader, parent, "robot", ("id", "x", "y", "yaw"), (), grid_map, "start pose")
    for element, robot_id, _ in robots:
        if not _NAMESPACE.fullmatch(robot_id):
            raise reader.fail(element, f"id {robot_id!r} is not a relative ROS namespace (the robot's: a letter first, "
                                       f"then letters, digits, _ and / between names)")
    return tuple(RobotSpec(robot_id, start) for _, robot_id, start in robots)


def _read_tasks(reader: _Reader, parent: ET.Element, grid_map: OccupancyMap) -> Tuple[TaskSpec, ...]:
    tasks: List[TaskSpec] = []
    for element, task_id, goal in _read_posed(reader, parent, "task", ("id", "category", "x", "y", "yaw"),
                                              ("service_time", "release"), grid_map, "goal"):
        service = reader.number(element, "service_time", default=0.0)
        if service < 0.0:
            raise reader.fail(element, f"service_time must not be negative, got {service:g}")
        release = reader.number(element, "release", default=0.0)
        if release < 0.0:
            raise reader.fail(element, f"release must not be negative, got {release:g}")
        tasks.append(TaskSpec(task_id, reader.text(element, "category"), goal, service, release))
    return tuple(tasks)


def _read_precedence(reader: _Reader, parent: Optional[ET.Element],
                     tasks: Sequence[TaskSpec]) -> Tuple[Tuple[int, ...], ...]:
    index = {task.id: i for i, task in enumerate(tasks)}
    preds: List[List[int]] = [[] for _ in tasks]
    if parent is None:
        return tuple(tuple(p) for p in preds)
    reader.attributes(parent, ())
    for element in reader.children(parent, "edge"):
        reader.attributes(element, ("before", "after"))
        ends = []
        for name in ("before", "after"):
            task_id = reader.text(element, name)
            if task_id not in index:
                raise reader.fail(element, f"unknown task '{task_id}'")
            ends.append(index[task_id])
        before, after = ends
        if before == after:
            raise reader.fail(element, "a task cannot precede itself")
        if before in preds[after]:
            raise reader.fail(element, "duplicate edge")
        preds[after].append(before)
    cycle = find_cycle(preds)
    if cycle:
        path = " -> ".join(tasks[i].id for i in cycle)
        raise reader.fail(parent, f"precedence has a cycle: {path}")
    return tuple(tuple(p) for p in preds)


def _read_faults(reader: _Reader, parent: Optional[ET.Element], robots: Sequence[RobotSpec]) -> Tuple[FaultSpec, ...]:
    """<faults>: at most one <fault robot at> per robot, `at` ≥ 0 s; in time order."""
    if parent is None:
        return ()
    reader.attributes(parent, ())
    index = {robot.id: i for i, robot in enumerate(robots)}
    faults: Dict[int, FaultSpec] = {}
    for element in reader.children(parent, "fault"):
        reader.attributes(element, ("robot", "at"))
        robot_id = reader.text(element, "robot")
        if robot_id not in index:
            raise reader.fail(element, f"unknown robot '{robot_id}'")
        if index[robot_id] in faults:
            raise reader.fail(element, f"robot '{robot_id}' given a fault more than once")
        at = reader.number(element, "at")
        if at < 0.0:
            raise reader.fail(element, f"at must not be negative, got {at:g}")
        faults[index[robot_id]] = FaultSpec(index[robot_id], at)
    return tuple(sorted(faults.values(), key=lambda fault: (fault.at, fault.robot)))


def find_cycle(preds: Sequence[Sequence[int]]) -> List[int]:
    """A cycle of the precedence graph as a list of task indices (first == last), or []."""
    state = [0] * len(preds)   # 0 unvisited, 1 on the stack, 2 done
    stack: List[int] = []

    def visit(node: int) -> List[int]:
        state[node] = 1
        stack.append(node)
        for pred in preds[node]:
            if state[pred] == 1:
                cycle = stack[stack.index(pred):] + [pred]
                return list(reversed(cycle))
            if state[pred] == 0:
                found = visit(pred)
                if found:
                    return found
        stack.pop()
        state[node] = 2
        return []

    for node in range(len(preds)):
        if state[node] == 0:
            found = visit(node)
            if found:
                return found
    return []


def _read_reward_overrides(reader: _Reader, parent: Optional[ET.Element]) -> Dict[str, Dict[str, float]]:
    raw: Dict[str, Dict[str, float]] = {}
    if parent is None:
        return raw
    reader.attributes(parent, ())
    for element in parent:
        if element.tag in raw:
            raise reader.fail(element, "given more than once")
        raw[element.tag] = {name: reader.number(element, name) for name in element.attrib}
    try:
        return check_reward_overrides(raw, f"{reader.path}: <reward>")
    except ConfigError as error:
        raise ScenarioError(str(error)) from None
