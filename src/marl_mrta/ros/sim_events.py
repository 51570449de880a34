"""Event mode on the simulator: env/executor.py's event interface for ros/executor.py's RosExecutor.

`dispatch(robot, task)` sends the robot's goal with the simulator paused and waits until its
move_base has taken it; `advance(until)` lets sim time run until the first of the running legs
ends, a leg reaches its deadline (its start + its own goal timeout, ros/event_legs.py: cancelled,
failed "goal timeout"), or
`until`, then reports the legs that ended, each robot's collision events since the last advance,
and the time in s of sim time since the episode's start. The other robots' goals run on across
events; service and holds are the rules' (the robots stand meanwhile).

Lock-step determinism as in synchronous mode (ros/executor.py's docstring): the simulator pauses
by itself on the tick on which the first watched goal ended (/simulator/run_until with
until_first_goal_end), or on the tick of the deadline or `until`, never on a request, which would
land a load-dependent number of ticks later with robots still moving; the legs that ended are
those whose controllers reported a goal end up to that tick in their answers to it, whatever
results have arrived by then. Robots whose controllers do not answer the lock-step (stock
move_base without stock_lockstep), and several arenas on one clock, are watched through their
results instead, as in synchronous mode. The episode's clock starts on the aligned tick before its
first dispatch, as a synchronous step does.

A live fleet (env/live_fleet.py): `stop(robot)` cancels the robot's goal within the paused tick
(no LegEnd); `add_goals` makes submitted tasks' goals dispatchable, each leg with its own timeout
from the extended table. A run-time request (`interrupted`) and a robot lost pause the simulator
on request, so that the transition ends there: in lock-step that pause lands a load-dependent
number of ticks later, which is inherent to a change from outside the simulation. With
`on_robot_fault: continue` a robot whose move_base process is gone while the lock-step waits for it
(ros/executor.py's _on_stall) is released from the lock-step and reported in `left`; the others
drive on. Otherwise a dead move_base aborts the episode, as before.
"""
from __future__ import annotations

import math
from typing import Callable, List, Optional, Tuple

import rospy

from marl_mrta.env.executor import EventAdvance, LegEnd
from marl_mrta.evaluation.nav_comparison import is_stale_success
from marl_mrta.ros.event_legs import GOAL_TIMEOUT, REACHED, Leg, LegBook, OutOfFleet
from marl_mrta.ros.move_base_link import await_accepted
from marl_mrta.ros.sim_clock import SimulatorLost, wait_wall
from marl_mrta.ros.ticks import first_tick_at, sim_elapsed


class SimEventMode:
    """Mixin of RosExecutor (its simulator link, move_base links, clock and helpers): event mode."""

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
        self._episode_start: Optional[float] = None   # sim time of the episode's start (its first event)
        self._collisions_from = 0.0
        self._event_time = 0.0

    # ------------------------------------------------------------------ EventExecutor

    def dispatch(self, robot: int, task: int) -> None:
        """The robot's goal, sent with the simulator paused and taken by its move_base before time
        runs on. A failure aborts the episode at the next advance() (with on_robot_fault continue, a
        move_base that is gone is this robot's fault alone)."""
        if self._lost is not None:
            return
        try:
            self._start_episode_clock()
            stamp, tick = self._event_now()
            goal = self.scenario.tasks[task].goal
            self.bases[robot].send(goal.x, goal.y, goal.yaw)
            self.legs.start(robot, task, max(self._since_start(stamp), self._event_time), stamp, tick)
            await_accepted(self.bases, [robot], self.lost_after)
        except SimulatorLost as lost:
            if not self._lose_if_gone([robot]):
                self._events_lost(str(lost))
            return
        if self.goal_listener is not None:
            self.goal_listener(robot, task)

    def advance(self, until: float) -> EventAdvance:
        if self._lost is not None:
            return self._events_aborted(self._lost)
        if self.instant_listener is not None:
            self.instant_listener(self._event_time)
        try:
            self._start_episode_clock()
            if not self._event_due():
                self._run_to_event(self._episode_start + self.legs.stop_time(until))
            return self._report(until)
        except SimulatorLost as lost:
            return self._events_aborted(str(lost))

    # ------------------------------------------------------------------ a live fleet

    def stop(self, robot: int) -> None:
        """The robot's leg ends now: its goal cancelled within the paused tick (no LegEnd)."""
        if self.legs.legs[robot] is None:
            return
        if robot not in self.out_of_fleet:
            self._cancel_leg(robot)
        self.legs.end(robot)

    def add_goals(self, scenario, table) -> None:
        """Tasks added at the end of scenario.tasks: their goals dispatchable, their legs timed."""
        self.scenario = scenario
        self.timeouts.extend(table.nominal_time)

    def let_go(self, robot: int) -> None:
        """The fleet let the robot go (a request, the scenario's fault): it stands (its goal was
        cancelled by stop()); its controller, if alive, answers the lock-step as before."""
        self.out_of_fleet.let_go(robot)

    def take_back(self, robot: int) -> None:
        """The robot joined again: its lock-step answers are waited for again (a move_base that is
        still gone is found again at the next stall)."""
        self.out_of_fleet.back(robot)
        self.sim.watch_again(robot)

    def _lose_if_gone(self, robots) -> bool:
        """With on_robot_fault continue while an episode runs: those of `robots` whose move_base
        process is gone leave the fleet (released from the lock-step, reported in `left`). True
        when one did."""
        if self.settings.on_robot_fault != "continue" or self._episode_start is None:
            return False
        gone = [i for i in robots if i not in self.out_of_fleet and self.bases[i].process_gone()]
        for i in gone:
            reason = f"{self.namespaces[i]}: move_base gone (its process does not answer)"
            if self.out_of_fleet.lose(i, reason):
                if self.sim.tracks_answers:
                    self.sim.release(i)
                rospy.logerr("robot fault: %s: %s alone stopped (on_robot_fault continue): it leaves the fleet, the "
                             "others go on", reason, self.namespaces[i])
        return bool(gone)

    # ------------------------------------------------------------------ helpers

    def _start_episode_clock(self) -> None:
        """The episode's time starts on an aligned tick, every controller caught up (as a step's)."""
        if self._episode_start is not None:
            return
        t0 = self._settle(align=True)
        if self.shared_clock:
            t0 = max(t0, self.clock.now())
        self._episode_start = self._collisions_from = t0

    def _event_now(self):
        """(sim time, tick) now: the paused tick, or on a shared clock the running time (tick 0)."""
        if self.shared_clock:
            return self.clock.now(), 0
        tick, stamp = self.sim.step(0)
        return stamp, tick

    def _since_start(self, stamp: float) -> float:
        return sim_elapsed(self._episode_start, stamp)

    def _goal_ended(self, robot: int, leg: Leg) -> bool:
        """Its controller reported a goal end after the leg's watch tick, or its result came."""
        if self._reports_goal_ends(robot) and self.sim.goal_end_tick(robot) > leg.watch_tick:
            return True
        return self.bases[robot].result is not None

    def _running(self) -> List[int]:
        """Robots with a leg under way that are in the fleet."""
        return [i for i in self.legs.running() if i not in self.out_of_fleet]

    def _a_leg_ended(self) -> bool:
        return any(self._goal_ended(i, self.legs.legs[i]) for i in self._running())

    def _event_due(self) -> bool:
        """A leg ended, a robot was lost, or a request waits: the transition ends now."""
        return self._a_leg_ended() or self.out_of_fleet.unreported() or self.interrupted()

    def _run_to_event(self, stop: float) -> None:
        """Sim time runs until the first running leg ends, or to the first tick at or after `stop`
        (sim time); then the simulator is paused and every controller has seen the tick."""
        rate = self.sim.config.physics_rate
        running = self._running()
        watched = [i for i in running if self._reports_goal_ends(i)]
        if not self.shared_clock:
            tick, stamp = self.sim.step(0)
            if tick >= first_tick_at(stop, rate):
                return
            self.sim.run_until(first_tick_at(stop, rate), [self.namespaces[i] for i in watched], 1,
                               first_goal_end=True)
        if self.clock.wait_until(self._event_due, stop) and watched:
            # The simulator pauses by itself on the first watched end's tick: wait until it has.
            ends = []
            for i in watched:
                leg, result = self.legs.legs[i], self.bases[i].result
                if leg is None or i in self.out_of_fleet:
                    continue
                if self.sim.goal_end_tick(i) > leg.watch_tick:
                    ends.append(self.sim.goal_end_tick(i))
                elif result is not None:
                    ends.append(int(round(result.stamp * rate)))
            if ends:
                pause = min(ends) / rate
                self.clock.wait_until(lambda: self.clock.now() >= pause - 1e-9, stop)
        self._pause(True)
        self.sim.wait_caught_up(*self.sim.step(0))

    def _report(self, until: float) -> EventAdvance:
        """The legs that ended by now (results, stale successes sent once more, deadlines)."""
        stamp, tick = self._event_now()
        now = max(self._since_start(stamp), self._event_time)
        left = self._take_lost()
        ended: List[LegEnd] = []
        for i in self._running():
            leg = self.legs.legs[i]
            if not self._goal_ended(i, leg):
                continue
            wait_wall(lambda: self.bases[i].result is not None, self.lost_after,
                      f"{self.namespaces[i]}/move_base ended its goal, but no result came")
            result = self.bases[i].result
            if self._stale_success(leg, result):
                leg.resent, leg.watch_tick = True, tick
                goal = self.scenario.tasks[leg.task].goal
                self.bases[i].send(goal.x, goal.y, goal.yaw)
                await_accepted(self.bases, [i], self.lost_after)
                continue
            if self._since_start(result.stamp) > leg.deadline + REACHED:
                continue   # ended after its deadline (a pause on request came late): a timeout, below
            ended.append(LegEnd(i, result.succeeded, "" if result.succeeded else result.describe()))
            self.legs.end(i, reached=result.succeeded)
        for i in [i for i in self.legs.overdue(now) if i not in self.out_of_fleet]:
            self._cancel_leg(i)
            ended.append(LegEnd(i, False, GOAL_TIMEOUT))
            self.legs.end(i)
        if stamp >= self._episode_start + until - REACHED:
            now = max(now, until)
        self._event_time = now
        collisions = self.sim.collisions_between(self._collisions_from, stamp)
        self._collisions_from = max(self._collisions_from, stamp)
        return EventAdvance(now, sorted(ended, key=lambda leg: leg.robot), collisions, left=left)

    def _take_lost(self) -> List[Tuple[int, str]]:
        """The robots lost since the last report, their legs ended (no LegEnd: they left)."""
        lost = self.out_of_fleet.take()
        for robot, _ in lost:
            self.legs.end(robot)
        return lost

    def _stale_success(self, leg: Leg, result) -> bool:
        """Stock move_base's stale success (ros/executor.py's StaleSuccessGuard), once per leg."""
        if leg.resent or not result.succeeded:
            return False
        pose = self.sim.poses()[leg.robot]
        goal = self.scenario.tasks[leg.task].goal
        distance = math.hypot(pose[0] - goal.x, pose[1] - goal.y) if pose is not None else None
        if not is_stale_success(True, result.stamp - leg.sent, distance):
            return False
        rospy.logwarn("%s: move_base reported goal %s reached %.2f s after it was sent, %.2f m away "
                      "(ros-planning/navigation#949): sent again", self.namespaces[leg.robot],
                      self.scenario.tasks[leg.task].id, result.stamp - leg.sent, distance)
        return True

    def _cancel_leg(self, robot: int) -> None:
        """A leg past its deadline: its goal cancelled (the built-in move_base stops within the
        paused tick; stock move_base only between recovery behaviours, and the robot's next goal
        replaces it)."""
        base = self.bases[robot]
        if base.idle:
            return
        base.cancel()
        try:
            wait_wall(lambda: base.idle, self.lost_after, "")
        except SimulatorLost:
            rospy.logwarn("%s: move_base has not ended the goal cancelled at its timeout (a recovery behaviour); "
                          "the robot's next goal replaces it", self.namespaces[robot])

    def _events_lost(self, reason: str) -> None:
        """The episode cannot go on: every goal cancelled, the simulator paused."""
        self._lost = reason
        for base in self.bases:
            base.cancel()
        try:
            self._pause(True)
        except SimulatorLost:
            pass

    def _events_aborted(self, reason: str) -> EventAdvance:
        self._events_lost(reason)
        now = self._event_time
        if self._episode_start is not None:
            now = max(now, self._since_start(self.clock.now()))
        self.legs.clear()
        return EventAdvance(now, [], [0] * self.n_robots, aborted=True, abort_reason=reason)
