"""How a decision step's goals get driven: the interface between the decision process and the robots.

The environment (env/task_env.py) owns every task rule; an executor only moves robots and
reports what happened to each one. Two implementations: the embedded executor
(env/embedded.py: travel times on the map, optional noise) and the ROS executor (goals
through each robot's move_base, arrival and failure from the action results, collisions from
the simulator).

Contract of one step:
1. `start_step(goals, time_limit)`: goals[i] is the task index robot i drives to, or None
   (stays where it is). Returns when every robot with a goal has arrived or failed, or when
   `time_limit` seconds (the rest of the episode) have passed, with one RobotOutcome per robot.
2. The environment applies the task rules and computes the step duration (arrival + service
   of the robot that finishes a task; the minimum idle step when all chose None).
3. `finish_step(duration)`: the executor lets time run to the step's end (an executor on a
   real clock waits out service and idle time; the embedded one only advances its clock).
A lost simulator or navigation sets `aborted` with a reason; the episode then ends.

Event mode (env/event_env.py) drives legs one robot at a time while the others drive on:
1. `dispatch(robot, task)`: the robot starts driving to the task now (the executor's clock).
2. `advance(until)`: time runs until the first leg ends, or until `until` (s since the episode's
   start) when none ends before; returns that time, the legs that ended then (reached or
   failed), and each robot's collision events meanwhile. Robots without a leg stand still.
A live fleet (env/live_fleet.py) also uses:
3. `stop(robot)`: the robot's leg ends now where it stands (a cancelled task, a robot leaving);
   no LegEnd is reported for it.
4. `add_goals(scenario, table)`: tasks were added (at the end of scenario.tasks, and of the
   table's nodes): their goals may be dispatched from now on.
An executor that loses one robot but can go on without it (real robots with on_robot_fault
continue) reports it in EventAdvance.left, after stopping it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional, Protocol, Sequence, Tuple

from marl_mrta.common.records import STEP_RECORD


@dataclass(**STEP_RECORD)
class RobotOutcome:
    """What one robot's navigation did during a step."""

    has_goal: bool
    reached: bool            # arrived at its goal within the step's time limit
    nav_time: float          # s from the step start to arrival, failure or the time limit (0 without goal)
    collisions: int = 0      # collision events (robot–robot or robot–obstacle) during the step
    failure: str = ""        # why it did not arrive ("" when it did or had no goal)


@dataclass(**STEP_RECORD)
class StepOutcome:
    robots: List[RobotOutcome]
    aborted: bool = False
    abort_reason: str = ""
    trajectories: Optional[List[List[Tuple[float, float, float]]]] = field(default=None)  # optional (t, x, y) per robot


@dataclass(**STEP_RECORD)
class LegEnd:
    """A leg that ended (event mode)."""

    robot: int
    reached: bool
    failure: str = ""        # why it did not arrive ("" when it did)


@dataclass(**STEP_RECORD)
class EventAdvance:
    """What advance() reports (event mode)."""

    time: float                          # s since the episode's start: the first leg end, or `until`
    legs: List[LegEnd]                   # legs that ended at `time`
    collisions: List[int]                # per robot, collision events since the last advance
    aborted: bool = False
    abort_reason: str = ""
    left: List[Tuple[int, str]] = field(default_factory=list)   # robots lost (stopped), with the reason


class EventExecutor(Protocol):
    """Moves the robots of one arena leg by leg (event mode); see the module docstring."""

    n_robots: int

    def reset(self, seed: Optional[int] = None) -> None:
        """Robots back to their start poses; the clock to 0."""

    def dispatch(self, robot: int, task: int) -> None:
        """The robot starts driving to the task at the current time."""

    def advance(self, until: float) -> EventAdvance:
        """Run until the first leg ends or `until`."""

    def poses(self) -> List[Tuple[float, float, float]]:
        """Current (x, y, yaw) of every robot in the map frame."""

    def stop(self, robot: int) -> None:
        """The robot's leg ends now (live fleet)."""

    def add_goals(self, scenario, table) -> None:
        """Tasks added at the end of scenario.tasks (live fleet)."""


class Executor(Protocol):
    """Moves the robots of one arena; see the module docstring for the step contract."""

    n_robots: int

    def reset(self, seed: Optional[int] = None) -> None:
        """Robots back to their start poses; seed any randomness of the execution."""

    def start_step(self, goals: Sequence[Optional[int]], time_limit: float) -> StepOutcome:
        """Drive robot i to task goals[i] (None: stay); return when all arrived or failed."""

    def finish_step(self, duration: float) -> None:
        """Let the step run to `duration` seconds after its start."""

    def poses(self) -> List[Tuple[float, float, float]]:
        """Current (x, y, yaw) of every robot in the map frame."""
