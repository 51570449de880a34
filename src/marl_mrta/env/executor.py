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
