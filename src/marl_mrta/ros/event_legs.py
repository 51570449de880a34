"""The legs under way in event mode (env/executor.py's event interface), ROS-free: both ROS executors
(ros/sim_events.py on the simulator, ros/real_events.py on real robots) keep them here.

A leg is one robot's goal from its dispatch to its end. Each has its own goal timeout
(model/goal_timeout.py's LegTimeouts: fixed, or with auto from the leg's nominal travel time from
where the robot stands, which the book follows as legs are reached): at `start + its timeout` it
is cancelled and reported failed ("goal timeout"), so a wait for the next event also ends at the
earliest leg deadline. Times are s since the episode's start, as the
environment counts them; `sent` is the clock's own time (sim or wall) at the dispatch, and
`watch_tick` the simulator's tick then: a goal end its controller reports on a later tick is this
leg's (0 on real robots).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Union

from marl_mrta.model.goal_timeout import GoalTimeout, LegTimeouts

#: s: a deadline or `until` this close to the clock counts as reached (a tick's stamp carries float error).
REACHED = 1e-6
GOAL_TIMEOUT = "goal timeout"


@dataclass
class Leg:
    robot: int
    task: int
    start: float         # s since the episode's start
    sent: float          # the clock's time (sim or wall) at the dispatch
    deadline: float      # s since the episode's start: start + the leg's own goal timeout
    watch_tick: int = 0  # the simulator's tick at the dispatch (or at a stale success's resend)
    resent: bool = False # its goal was sent once more after a stale success (ros/executor.py)


class LegBook:
    """Per robot its leg under way, or None; and where each robot stands (`timeouts`), from
    which its next leg's goal timeout is taken. `timeouts`: a LegTimeouts, or fixed seconds."""

    def __init__(self, n_robots: int, timeouts: Union[LegTimeouts, float]):
        self.n_robots = n_robots
        self.timeouts = timeouts if isinstance(timeouts, LegTimeouts) else LegTimeouts(GoalTimeout(float(timeouts)),
                                                                                      n_robots)
        self.legs: List[Optional[Leg]] = [None] * n_robots

    def clear(self) -> None:
        self.legs = [None] * self.n_robots

    def reset(self) -> None:
        """An episode's start: no leg, every robot on its start pose."""
        self.clear()
        self.timeouts.reset()

    def start(self, robot: int, task: int, start: float, sent: float, watch_tick: int = 0) -> Leg:
        leg = Leg(robot, task, start, sent, start + self.timeouts.limit(robot, task), watch_tick)
        self.legs[robot] = leg
        return leg

    def end(self, robot: int, reached: bool = False) -> None:
        """The robot's leg ended; `reached`: at its goal, where its next leg starts."""
        leg = self.legs[robot]
        if reached and leg is not None:
            self.timeouts.reached(robot, leg.task)
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
