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

import threading
from dataclasses import dataclass
from typing import List, Optional, Set, Tuple, Union

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


class OutOfFleet:
    """The robots an executor no longer drives, and its own losses not yet reported (`take`). A
    robot is out when the executor lost it (`lose`: a fault of its own, on_robot_fault continue) or
    the fleet let it go (`let_go`: a request, the scenario's fault); `back` when it joins. Thread-safe:
    a watchdog may report a loss while the episode's thread waits."""

    def __init__(self):
        self._lock = threading.Lock()
        self._out: Set[int] = set()
        self._unreported: List[Tuple[int, str]] = []
        self._losses: List[Tuple[int, str]] = []   # every loss of the episode, in order

    def lose(self, robot: int, reason: str) -> bool:
        """The executor lost the robot; False when it was out already (nothing to report)."""
        with self._lock:
            if robot in self._out:
                return False
            self._out.add(robot)
            self._unreported.append((robot, reason))
            self._losses.append((robot, reason))
            return True

    def let_go(self, robot: int) -> bool:
        """The fleet let the robot go; False when it was out already."""
        with self._lock:
            if robot in self._out:
                return False
            self._out.add(robot)
            return True

    def back(self, robot: int) -> None:
        with self._lock:
            self._out.discard(robot)
            self._unreported = [(r, why) for r, why in self._unreported if r != robot]

    def take(self) -> List[Tuple[int, str]]:
        """The losses not reported yet, in the order they happened."""
        with self._lock:
            taken, self._unreported = self._unreported, []
        return taken

    def losses(self) -> List[Tuple[int, str]]:
        """Every robot the executor lost in this episode, with the reason, in order."""
        with self._lock:
            return list(self._losses)

    def unreported(self) -> bool:
        with self._lock:
            return bool(self._unreported)

    def clear(self) -> None:
        """A new episode: every robot in the fleet."""
        with self._lock:
            self._out.clear()
            self._unreported = []
            self._losses = []

    def __contains__(self, robot: int) -> bool:
        with self._lock:
            return robot in self._out
