"""How long a robot may take to reach a goal, and how long an episode may last when the scenario
leaves it to the floor: the one rule every executor and the planners use (ROS-free).

GoalTimeout is either a fixed number of seconds per leg (`goal_timeout: 60.0`, the paper's rule)
or `auto`: each leg gets `factor × its nominal travel time + margin`, the nominal time being the
travel table's (model/travel.py, the planners' table) from the node the robot stands on (its
start pose, or the goal of the task it last reached) to the goal. A building-size floor then
needs no configuration edit: its long legs get long timeouts, its short legs short ones.

Where the rule comes from, last wins: config/task.yaml (`goal_timeout`, `goal_timeout_factor`,
`goal_timeout_margin`), the scenario's `<episode goal_timeout="...">`, a command line's
`--goal-timeout` or a launch file's `goal_timeout:=` (env/settings.py, TaskSettings.for_scenario).

LegTimeouts keeps, per robot, the node it stands on and gives each leg its own timeout; the ROS
executors (ros/executor.py, ros/real_executor.py, ros/event_legs.py) keep one per episode.
`auto_episode_timeout` is the episode timeout of a scenario whose `<episode timeout="auto">`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import List, Optional, Sequence, Union

from marl_mrta.common.config import ConfigError

#: The value that makes a goal or episode timeout follow the floor.
AUTO = "auto"

#: A timeout as written: seconds, or AUTO.
TimeoutValue = Union[float, str]


def parse_timeout(value: object) -> TimeoutValue:
    """`auto`, or a positive, finite number of seconds (a number or its text); ValueError with the
    problem (one phrase) otherwise."""
    if isinstance(value, str):
        text = value.strip()
        if text.lower() == AUTO:
            return AUTO
        try:
            number = float(text)
        except ValueError:
            raise ValueError(f"is not a number of seconds or auto: {value!r}") from None
    elif isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"is not a number of seconds or auto: {value!r}")
    else:
        number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"is not finite: {value!r}")
    if number <= 0.0:
        raise ValueError(f"must be positive, got {number:g}")
    return number


def check_goal_timeout(value: object, where: str) -> Optional[TimeoutValue]:
    """A goal timeout given on a command line or as a parameter: seconds > 0 or 'auto'; None or ''
    (not given) -> None. ConfigError `WHERE: PROBLEM` (one line) otherwise."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return None
    try:
        return parse_timeout(value)
    except ValueError as problem:
        raise ConfigError(f"{where}: {problem}") from None


def describe_timeout(value: TimeoutValue) -> str:
    """'auto' or '60 s'."""
    return AUTO if value == AUTO else f"{float(value):g} s"


@dataclass(frozen=True)
class GoalTimeout:
    """The goal timeout rule: `seconds` fixed per leg, or with seconds None (auto) each leg's
    `factor × nominal + margin`."""

    seconds: Optional[float] = None   # s per leg; None: auto
    factor: float = 2.0               # auto: times the leg's nominal travel time
    margin: float = 30.0              # auto: s added

    @property
    def auto(self) -> bool:
        return self.seconds is None

    @property
    def value(self) -> TimeoutValue:
        """As written in a file or a parameter: the seconds, or 'auto'."""
        return AUTO if self.seconds is None else self.seconds

    def leg(self, nominal_seconds: float) -> float:
        """s a leg of this nominal travel time may take before it fails."""
        if self.seconds is not None:
            return self.seconds
        return self.factor * nominal_seconds + self.margin

    @property
    def planning_limit(self) -> float:
        """The longest leg a plan may use (baselines/plan.py's SchedulingInstance.goal_timeout):
        the fixed timeout, or with auto every finite leg (inf): a leg's own timeout is always
        longer than its nominal time."""
        return self.seconds if self.seconds is not None else math.inf

    def with_value(self, value: Optional[TimeoutValue]) -> "GoalTimeout":
        """This rule overridden by `value` (seconds or 'auto'); None: unchanged."""
        if value is None:
            return self
        if value == AUTO:
            return replace(self, seconds=None)
        return replace(self, seconds=float(value))


class LegTimeouts:
    """Each leg's own goal timeout: the rule applied to the travel table's nominal time from the
    node the robot stands on (its start at reset(), the goal of the task it last reached) to the
    goal. `nominal_time`: the table's (n_nodes, n_nodes) seconds, nodes the robots' starts then
    the tasks' goals; not needed with a fixed rule."""

    def __init__(self, rule: GoalTimeout, n_robots: int, nominal_time: Optional[Sequence[Sequence[float]]] = None):
        if rule.auto and nominal_time is None:
            raise ValueError("an auto goal timeout needs the travel table's nominal times")
        self.rule = rule
        self.n_robots = n_robots
        self.nominal = [list(map(float, row)) for row in nominal_time] if nominal_time is not None else None
        self.nodes: List[int] = list(range(n_robots))

    def reset(self) -> None:
        """Every robot on its start pose (an episode's start)."""
        self.nodes = list(range(self.n_robots))

    def limit(self, robot: int, task: int) -> float:
        """s the robot's leg to `task` may take, from where it stands."""
        if self.nominal is None:
            return self.rule.leg(0.0)
        return self.rule.leg(self.nominal[self.nodes[robot]][self.n_robots + task])

    def extend(self, nominal_time: Sequence[Sequence[float]]) -> None:
        """Tasks were added (a live fleet): the table of every node, the new goals' after the
        others' (the nodes the robots stand on keep their indices). Nothing to do with a fixed rule."""
        if self.nominal is not None:
            self.nominal = [list(map(float, row)) for row in nominal_time]

    def reached(self, robot: int, task: int) -> None:
        """The robot reached the task's goal: its next leg starts there."""
        self.nodes[robot] = self.n_robots + task

    def step_limit(self, goals: Sequence[Optional[int]]) -> float:
        """s a synchronous step with these goals may wait: its longest leg's timeout (the fixed
        timeout when no robot has a goal)."""
        limits = [self.limit(robot, task) for robot, task in enumerate(goals) if task is not None]
        return max(limits) if limits else (self.rule.seconds or 0.0)


def auto_episode_timeout(nominal_time: Sequence[Sequence[float]], n_robots: int,
                         service_times: Sequence[float], factor: float) -> float:
    """The episode timeout of `<episode timeout="auto">`: `factor` × the sum over tasks of (the
    shortest leg into the task, from any start or other goal, + its service time), rounded up
    to whole 10 s: one robot doing every task alone over its shortest legs, times `factor`."""
    total = 0.0
    for j, service in enumerate(service_times):
        node = n_robots + j
        legs = [float(row[node]) for a, row in enumerate(nominal_time) if a != node]
        total += min(legs, default=0.0) + float(service)
    return max(10.0, 10.0 * math.ceil(factor * total / 10.0))
