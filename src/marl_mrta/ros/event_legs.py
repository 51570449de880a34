"""The legs under way in event mode (env/executor.py's event interface), ROS-free: both ROS executors
(ros/sim_events.py on the simulator, ros/real_events.py on real robots) keep them here.

A leg is one robot's goal from its dispatch to its end. Each has its own goal timeout: at
`start + goal_timeout` it is cancelled and reported failed ("goal timeout"), so a wait for the
next event also ends at the earliest leg deadline. Times are s since the episode's start, as the
environment counts them; `sent` is the clock's own time (sim or wall) at the dispatch, and
`watch_tick` the simulator's tick then: a goal end its controller reports on a later tick is this
leg's (0 on real robots).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional

#: s: a deadline or `until` this close to the clock counts as reached (a tick's stamp carries float error).
REACHED = 1e-6
GOAL_TIMEOUT = "goal timeout"


@dataclass
class Leg:
    robot: int
    task: int
    start: float         # s since the episode's start
    sent: float          # the clock's time (sim or wall) at the dispatch
    deadline: float      # s since the episode's start: start + goal_timeout
    watch_tick: int = 0  # the simulator's tick at the dispatch (or at a stale success's resend)
    resent: bool = False # its goal was sent once more after a stale success (ros/executor.py)


class LegBook:
    """Per robot its leg under way, or None."""

    def __init__(self, n_robots: int, goal_timeout: float):
        self.n_robots = n_robots
        self.goal_timeout = goal_timeout
        self.legs: List[Optional[Leg]] = [None] * n_robots

    def clear(self) -> None:
        self.legs = [None] * self.n_robots

    def start(self, robot: int, task: int, start: float, sent: float, watch_tick: int = 0) -> Leg:
        leg = Leg(robot, task, start, sent, start + self.goal_timeout, watch_tick)
        self.legs[robot] = leg
        return leg

    def end(self, robot: int) -> None:
        self.legs[robot] = None

    def running(self) -> List[int]:
        """The robots with a leg under way, in index order."""
        return [i for i, leg in enumerate(self.legs) if leg is not None]

    def stop_time(self, until: float) -> float:
        """When a wait for the next event must end at the latest: `until`, or the earliest leg
        deadline before it."""
        return min([until] + [leg.deadline for leg in self.legs if leg is not None])

    def overdue(self, now: float) -> List[int]:
        """Robots whose leg is past its deadline at `now`."""
        return [i for i, leg in enumerate(self.legs) if leg is not None and leg.deadline <= now + REACHED]
