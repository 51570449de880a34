"""Event mode on real robots (or the hardware stand-in): env/executor.py's event interface for
ros/real_executor.py's RealExecutor, on wall time.

`dispatch(robot, task)` sends the robot's goal at once and waits until its move_base has taken it;
`advance(until)` waits until the first running leg reaches its goal, a leg reaches its deadline
(its start + its own goal timeout, ros/event_legs.py: cancelled, failed "goal timeout"), or
`until`, and reports the legs that ended at that moment (s of wall time since the episode's
start, which is the first dispatch after the operator's go). The other robots drive on across events, and also while the client decides;
service and holds are the rules' (the robots stand meanwhile).

Every safety stop stays as in synchronous mode: a fault (a silent robot, a lost master, a lost
robot, the e-stop, the node shutting down) or a goal move_base ends other than by reaching it
stops every robot (ros/fleet_link.py's FleetStop: the drive permit withdrawn, every goal
cancelled, zero cmd_vel) and aborts the episode with the reason. No collision events: real
robots report none.
"""
from __future__ import annotations

import time
from typing import Callable, List, Optional

import rospy

from marl_mrta.env.executor import EventAdvance, LegEnd
from marl_mrta.ros.event_legs import GOAL_TIMEOUT, REACHED, LegBook
from marl_mrta.ros.move_base_link import await_accepted, cancel_running
from marl_mrta.ros.sim_clock import SimulatorLost

#: How often the executor looks at results, the clock and the monitor while it waits [wall s].
POLL = 0.01


class RealEventMode:
    """Mixin of RealExecutor (its move_base links, safety monitor and stop): event mode."""

    def _init_events(self) -> None:
        self.legs = LegBook(self.n_robots, self.timeouts)
        #: Called with (robot, task) once a goal is sent and taken (the task manager's /<robot>/goal).
        self.goal_listener: Optional[Callable[[int, int], None]] = None
        self._reset_events()

    def _reset_events(self) -> None:
        self.legs.reset()
        self._episode_start: Optional[float] = None   # wall time of the episode's first event
        self._event_time = 0.0

    # ------------------------------------------------------------------ EventExecutor

    def dispatch(self, robot: int, task: int) -> None:
        """The robot's goal, taken by its move_base; a fault aborts the episode at the next advance()."""
        if self._lost is not None or self.monitor.tripped:
            return
        now = self._event_clock()
        goal = self.scenario.tasks[task].goal
        self.bases[robot].send(goal.x, goal.y, goal.yaw)
        self.legs.start(robot, task, max(now - self._episode_start, self._event_time), now)
        try:
            await_accepted(self.bases, [robot], self.settings.simulator_lost_after, stop=lambda: self.monitor.tripped)
        except SimulatorLost as lost:
            self._lost = str(lost)
            self.trip(self._lost)
            return
        if not self.monitor.tripped and self.goal_listener is not None:
            self.goal_listener(robot, task)

    def advance(self, until: float) -> EventAdvance:
        if self._lost is not None or self.monitor.tripped:
            return self._events_aborted(self._lost or self.monitor.reason)
        self._event_clock()
        start = self._episode_start
        stop = self.legs.stop_time(until)
        while True:
            running = self.legs.running()
            failed = self._failed_goal(running)
            if failed or self.monitor.tripped:
                return self._events_aborted(self.monitor.reason or failed)
            now = max(rospy.get_time() - start, self._event_time)
            reached = [i for i in running if self.bases[i].result is not None]
            if reached or now >= stop - REACHED:
                break
            if rospy.is_shutdown():
                return self._events_aborted(self.monitor.reason or "node shutting down")
            time.sleep(POLL)
        ended: List[LegEnd] = []
        for i in reached:   # _failed_goal let only successes through
            ended.append(LegEnd(i, True))
            self.legs.end(i, reached=True)
        overdue = self.legs.overdue(now)
        if overdue:
            # Stock move_base ends a goal only between recovery behaviours: a cancel gets cancel_wait.
            try:
                cancel_running([self.bases[i] for i in overdue], self.settings.cancel_wait)
            except SimulatorLost as lost:
                return self._events_aborted(str(lost))
            for i in overdue:
                ended.append(LegEnd(i, False, GOAL_TIMEOUT))
                self.legs.end(i)
        if now >= until - REACHED:
            now = max(now, until)
        self._event_time = now
        return EventAdvance(now, sorted(ended, key=lambda leg: leg.robot), [0] * self.n_robots)

    # ------------------------------------------------------------------ helpers

    def _event_clock(self) -> float:
        """Wall time now; the episode's time starts at its first event."""
        now = rospy.get_time()
        if self._episode_start is None:
            self._episode_start = now
        return now

    def _events_aborted(self, reason: str) -> EventAdvance:
        """Every robot stopped (the first reason of a stop stays); the episode ends with `reason`."""
        self._lost = reason
        self.trip(reason)
        now = self._event_time
        if self._episode_start is not None:
            now = max(now, rospy.get_time() - self._episode_start)
        self.legs.clear()
        return EventAdvance(now, [], [0] * self.n_robots, aborted=True, abort_reason=reason)
