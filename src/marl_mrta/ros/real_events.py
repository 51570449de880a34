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

A live fleet (env/live_fleet.py): `stop(robot)` cancels the robot's goal and lets it stand (a
cancelled task; a robot that leaves is also let go: `let_go`, its drive permit withdrawn and zero
cmd_vel); `add_goals` makes submitted tasks' goals dispatchable, each leg with its own timeout from
the extended table. With `on_robot_fault: continue`, a fault that concerns one robot while an
episode runs (its odometry, scan or move_base silent, its localisation lost, a goal move_base
aborted or did not take) stops that robot alone (FleetStop.stop_robot, at once, from the watchdog's
thread) and the next advance() reports it in `left`; the others drive on. Faults of the fleet (the
master, the e-stop, the node shutting down) stop every robot as before. A request waiting
(`interrupted`) ends a wait at once, so that it applies between two instants.
"""
from __future__ import annotations

import time
from typing import Callable, List, Optional, Tuple

import rospy

from marl_mrta.env.executor import EventAdvance, LegEnd
from marl_mrta.ros.event_legs import GOAL_TIMEOUT, REACHED, LegBook, OutOfFleet
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
        #: Called at the start of each advance() with the time of the instant (the task manager's ~fleet_status).
        self.instant_listener: Optional[Callable[[float], None]] = None
        #: True while a run-time request waits: a wait ends at once (the task manager's queue).
        self.interrupted: Callable[[], bool] = lambda: False
        self.out_of_fleet = OutOfFleet()
        self._reset_events()

    def _reset_events(self) -> None:
        self.legs.reset()
        self.out_of_fleet.clear()
        self._episode_start: Optional[float] = None   # wall time of the episode's first event
        self._event_time = 0.0

    # ------------------------------------------------------------------ a live fleet

    def stop(self, robot: int) -> None:
        """The robot's leg ends now: its goal cancelled, the robot stands (no LegEnd)."""
        if self.legs.legs[robot] is not None:
            self.bases[robot].cancel()
            self.legs.end(robot)

    def add_goals(self, scenario, table) -> None:
        """Tasks added at the end of scenario.tasks: their goals dispatchable, their legs timed."""
        self.scenario = scenario
        self.timeouts.extend(table.nominal_time)

    def let_go(self, robot: int) -> None:
        """The fleet let the robot go (a request, the scenario's fault): it stands, its drive permit
        withdrawn, zero cmd_vel, its silence no longer watched."""
        if self.out_of_fleet.let_go(robot):
            self.monitor.excuse(robot)
            self._stop_alone(robot)

    def take_back(self, robot: int) -> None:
        """The robot joined again: watched again, and it may drive once the fleet may."""
        self.out_of_fleet.back(robot)
        self.monitor.watch_again(robot)
        self._permit_again(robot)

    def robot_fault(self, robot: int, reason: str) -> None:
        """A fault of one robot (the watchdog's, a goal aborted or not taken): with on_robot_fault
        continue while an episode runs, that robot alone is stopped and reported in the next
        advance's `left`; otherwise every robot is stopped (a trip)."""
        if not self._continuing():
            self.trip(reason)
            return
        if not self.out_of_fleet.lose(robot, reason):
            return
        self.monitor.excuse(robot)
        self._stop_alone(robot)
        rospy.logerr("robot fault: %s: %s alone stopped (on_robot_fault continue): its goals cancelled, zero "
                     "cmd_vel; it leaves the fleet, the others go on", reason, self.namespaces[robot])

    def _continuing(self) -> bool:
        """A fault of one robot stops it alone: on_robot_fault continue, while an episode runs."""
        return (self.settings.on_robot_fault == "continue" and self._episode_start is not None
                and not self.monitor.tripped)

    def _stop_alone(self, robot: int) -> None:
        self.fleet_stop.stop_robot(robot)

    def _permit_again(self, robot: int) -> None:
        self.fleet_stop.grant_robot(robot)

    # ------------------------------------------------------------------ EventExecutor

    def dispatch(self, robot: int, task: int) -> None:
        """The robot's goal, taken by its move_base; a fault aborts the episode at the next advance()
        (with on_robot_fault continue, a goal this robot's move_base does not take is its own fault)."""
        if self._lost is not None or self.monitor.tripped:
            return
        now = self._event_clock()
        goal = self.scenario.tasks[task].goal
        self.bases[robot].send(goal.x, goal.y, goal.yaw)
        self.legs.start(robot, task, max(now - self._episode_start, self._event_time), now)
        try:
            await_accepted(self.bases, [robot], self.settings.simulator_lost_after, stop=lambda: self.monitor.tripped)
        except SimulatorLost as lost:
            if self._continuing():
                self.robot_fault(robot, str(lost))
            else:
                self._lost = str(lost)
                self.trip(self._lost)
            return
        if not self.monitor.tripped and self.goal_listener is not None:
            self.goal_listener(robot, task)

    def advance(self, until: float) -> EventAdvance:
        if self._lost is not None or self.monitor.tripped:
            return self._events_aborted(self._lost or self.monitor.reason)
        self._event_clock()
        if self.instant_listener is not None:
            self.instant_listener(self._event_time)
        start = self._episode_start
        stop = self.legs.stop_time(until)
        while True:
            failed = self._failed_goals(self._running())
            if failed and not self._continuing():
                return self._events_aborted(self.monitor.reason or failed[0][1])
            for robot, reason in failed:   # each stopped alone
                self.robot_fault(robot, reason)
            if self.monitor.tripped:
                return self._events_aborted(self.monitor.reason)
            now = max(rospy.get_time() - start, self._event_time)
            running = self._running()
            reached = [i for i in running if self.bases[i].result is not None and self.bases[i].result.succeeded]
            if reached or now >= stop - REACHED or self.out_of_fleet.unreported() or self.interrupted():
                break
            if rospy.is_shutdown():
                return self._events_aborted(self.monitor.reason or "node shutting down")
            time.sleep(POLL)
        left = self._take_lost()
        ended: List[LegEnd] = []
        for i in [i for i in reached if i not in self.out_of_fleet]:
            ended.append(LegEnd(i, True))
            self.legs.end(i, reached=True)
        overdue = [i for i in self.legs.overdue(now) if i not in self.out_of_fleet]
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
        return EventAdvance(now, sorted(ended, key=lambda leg: leg.robot), [0] * self.n_robots, left=left)

    # ------------------------------------------------------------------ helpers

    def _running(self) -> List[int]:
        """Robots with a leg under way that are in the fleet."""
        return [i for i in self.legs.running() if i not in self.out_of_fleet]

    def _take_lost(self) -> List[Tuple[int, str]]:
        """The robots lost since the last report, their legs ended (no LegEnd: they left)."""
        lost = self.out_of_fleet.take()
        for robot, _ in lost:
            self.legs.end(robot)
        return lost

    def _failed_goals(self, robots) -> List[Tuple[int, str]]:
        """(robot, reason) of each goal move_base ended other than by reaching it."""
        failed = []
        for i in robots:
            result = self.bases[i].result
            if result is not None and not result.succeeded:
                failed.append((i, f"{self.namespaces[i]}: {result.describe()}"))
        return failed

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
