"""The real executor: a decision step's goals driven by real robots (or the hardware stand-in),
on wall time. Implements env.executor.Executor beside ros/executor.py (the simulation's), and in
event mode its event interface (ros/real_events.py), so the decision process and every task rule
stay the one ROS-free implementation.

What differs from the simulation (docs/guide/real_robots.md): time is the wall clock, no /clock and no
simulator; a reset cannot teleport: every robot drives to its start pose through its move_base,
one at a time by default (`reset_drive`; `reset: current` takes the poses where they stand
instead), then the episode waits for the operator's go (~go, or `go: true` unattended). Every
fault stops every robot at once: a robot whose odometry, scan or move_base falls silent, a robot
whose scan stops fitting the map where localisation puts it (lost), a lost ROS master
(ros/fleet_link.py watches, ros/safety.py decides), a goal move_base aborts, the e-stop, the
node shutting down. A stop withdraws the drive permit of the robots' cmd_vel gates,
cancels every goal and sends zero cmd_vel (held for `stop_hold`); the step returns `aborted`
with the reason, which ends the episode (env/task_env.py) and names the robot and the part; in event
mode with `on_robot_fault: continue` a fault of one robot stops it alone (ros/real_events.py).
Goal timeouts are the simulation's: each leg its own (ros/executor.py), on wall time.
"""
from __future__ import annotations

import threading
import time
from typing import List, Optional, Sequence, Tuple

import rospy
import tf2_ros

from marl_mrta.env.executor import RobotOutcome, StepOutcome
from marl_mrta.model.fleet import reset_groups
from marl_mrta.model.goal_timeout import LegTimeouts
from marl_mrta.model.scenario import Scenario, footprint_spacing
from marl_mrta.ros.fleet_link import FleetStop, FleetWatch, ScanFitWatch
from marl_mrta.ros.localization_link import LocalizationLink
from marl_mrta.ros.manager_settings import RealRobotSettings, RosExecutorSettings
from marl_mrta.ros.move_base_link import MoveBaseLink, await_accepted, cancel_running, send_goals
from marl_mrta.ros.real_events import RealEventMode
from marl_mrta.ros.safety import SafetyMonitor
from marl_mrta.ros.sim_clock import SimulatorLost, wait_wall
from marl_mrta.ros.sim_link import quaternion_to_yaw

#: How often the executor looks at results, the clock and the monitor while it waits [wall s].
POLL = 0.01


class RealExecutor(RealEventMode):
    """Executor over the move_base, amcl and base of every real robot of one fleet; in event mode
    the event interface of ros/real_events.py."""

    def __init__(self, scenario: Scenario, settings: RosExecutorSettings, real: RealRobotSettings,
                 timeouts: LegTimeouts):
        self.scenario = scenario
        self.settings = settings
        self.timeouts = timeouts   # each leg's goal timeout, from where its robot stands (ros/executor.py)
        self.real = real
        self.n_robots = scenario.n_robots
        self.namespaces = [settings.robot_prefix + robot.id for robot in scenario.robots]
        self.bases = [MoveBaseLink("/" + ns, settings.map_frame) for ns in self.namespaces]
        self.localizers = [LocalizationLink("/" + ns, settings.map_frame) for ns in self.namespaces]
        self.monitor = SafetyMonitor(self.namespaces, real.limits)
        self.fleet_stop = FleetStop(self.namespaces, self.bases, real.stop_hold)
        self.tf = tf2_ros.Buffer()
        self._tf_listener = tf2_ros.TransformListener(self.tf)
        self._starts = [(r.start.x, r.start.y, r.start.yaw) for r in scenario.robots]
        self._go = threading.Event()
        self.waiting_for_go = False
        self._step_start = 0.0
        self._lost: Optional[str] = None   # a fault after a step's goals: the next step is aborted
        self._watch: Optional[FleetWatch] = None
        self._scan_fit: Optional[ScanFitWatch] = None
        self._init_events()

    # ------------------------------------------------------------------ start-up, operator, faults

    def wait_for_graph(self) -> None:
        """Blocks until every robot's base, move_base and amcl answer; raises SimulatorLost if not."""
        wait = self.settings.graph_wait
        wait_wall(lambda: not self.fleet_stop.robots_not_listening(), wait,
                  lambda: "no base listens on cmd_vel of " + ", ".join(self.fleet_stop.robots_not_listening()))
        for base in self.bases:
            wait_wall(base.connected, wait, f"{base.server_name} did not connect")
        for link in self.localizers:
            wait_wall(link.connected, wait, f"{link.namespace}/amcl did not subscribe to initialpose")
        if self.real.limits.scan_fit_min > 0.0:
            self._scan_fit = ScanFitWatch(self.namespaces, self.scenario.load_map(), self.tf, self.settings.map_frame,
                                          self.monitor)
        self._watch = FleetWatch(self.namespaces, self.monitor, self.trip, self.fleet_stop.send_permit,
                                 self._scan_fit, on_robot_fault=self.robot_fault)
        wait_wall(lambda: not self.monitor.missing(), wait, lambda: "nothing heard of " + ", ".join(self.monitor.missing()))
        wait_wall(lambda: all(link.pose() is not None for link in self.localizers), wait,
                  lambda: "no amcl_pose from " + ", ".join(link.namespace for link in self.localizers
                                                          if link.pose() is None))
        self.monitor.rearm(time.monotonic())
        rospy.loginfo("real robots %s: bases, move_base and amcl answer (wall time)", ", ".join(self.namespaces))

    def trip(self, reason: str, log: bool = True) -> None:
        """Stops every robot for `reason` (the first reason of a stop stays until the next reset)."""
        if self.monitor.trip(reason, time.monotonic()):
            self.fleet_stop.stop()
            if log:
                    rospy.logerr("safe stop: %s: every goal cancelled, zero cmd_vel sent to %s", reason,
                             ", ".join(self.namespaces))

    def give_go(self) -> bool:
        """The operator's go; False when no episode waits for one."""
        if not self.waiting_for_go:
            return False
        self._go.set()
        return True

    # ------------------------------------------------------------------ Executor

    def reset(self, seed: Optional[int] = None) -> None:
        """Stops what runs, then drives every robot to its start pose (or takes where it stands)
        and waits for the operator's go. Real robots have no noise streams: `seed` changes nothing."""
        self._reset_events()
        self.fleet_stop.grant_robot()   # every robot in the fleet again (a robot stopped alone included)
        now = time.monotonic()
        self.monitor.rearm(now)
        fault = self.monitor.fault(now)
        if fault:
            self.trip(fault)
            raise SimulatorLost(f"the robots cannot start an episode: {fault}")
        self._cancel_own()
        if self.real.reset == "start":
            self._drive_to_starts()
        else:
            self._starts = [(x, y, yaw) for x, y, yaw in self.poses()]
        self._await_go()
        self._lost = None

    def start_step(self, goals: Sequence[Optional[int]], time_limit: float) -> StepOutcome:
        if self._lost is not None or self.monitor.tripped:
            return self._aborted(goals, None, self._lost or self.monitor.reason)
        t0 = rospy.get_time()
        self._step_start = t0
        pending = send_goals(self.bases, self.scenario.tasks, goals)
        # Each robot's own limit (ros/executor.py); the step waits for the longest.
        limits = [min(time_limit, self.timeouts.limit(i, g)) if g is not None else 0.0 for i, g in enumerate(goals)]
        deadline = t0 + min(time_limit, self.timeouts.step_limit(goals))
        try:
            await_accepted(self.bases, pending, self.settings.simulator_lost_after, stop=lambda: self.monitor.tripped)
        except SimulatorLost as lost:
            return self._aborted(goals, t0, str(lost))
        while not all(self.bases[i].result is not None for i in pending) and rospy.get_time() < deadline:
            failed = self._failed_goal(pending)
            if failed or self.monitor.tripped:
                return self._aborted(goals, t0, self.monitor.reason or failed)
            time.sleep(POLL)
        failed = self._failed_goal(pending)
        if failed or self.monitor.tripped:
            return self._aborted(goals, t0, self.monitor.reason or failed)
        try:
            # At the deadline: a goal timeout. Stock move_base ends a goal only between recovery
            # behaviours (a turn in place takes about 7 s), so a cancel gets cancel_wait.
            cancel_running(self.bases, self.settings.cancel_wait)
        except SimulatorLost as lost:
            return self._aborted(goals, t0, str(lost))
        robots = []
        for i, goal in enumerate(goals):
            result, limit = self.bases[i].result, limits[i]
            if goal is None:
                robots.append(RobotOutcome(has_goal=False, reached=False, nav_time=0.0))
            elif result is not None and result.succeeded and result.stamp <= t0 + limit + 1e-9:
                robots.append(RobotOutcome(True, True, min(max(0.0, result.stamp - t0), limit)))
                self.timeouts.reached(i, goal)
            else:
                robots.append(RobotOutcome(True, False, limit, failure="goal timeout"))
        return StepOutcome(robots=robots)

    def finish_step(self, duration: float) -> None:
        """Waits out the step's service and idle time on the wall clock (the robots stand)."""
        end = self._step_start + duration
        while self._lost is None and rospy.get_time() < end - 1e-6:
            if self.monitor.tripped:
                self._lost = self.monitor.reason   # reported as the abort of the next step
                return
            time.sleep(POLL)

    def poses(self) -> List[Tuple[float, float, float]]:
        """map -> base_footprint of every robot (amcl's map -> odom and the odometry), else its
        latest amcl_pose, else its start pose."""
        poses = []
        for ns, link, start in zip(self.namespaces, self.localizers, self._starts):
            try:
                t = self.tf.lookup_transform(self.settings.map_frame, ns + "/base_footprint", rospy.Time(0)).transform
                poses.append((t.translation.x, t.translation.y, quaternion_to_yaw(t.rotation)))
                continue
            except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException):
                pass
            estimate = link.pose()
            poses.append(estimate[1:] if estimate is not None else start)
        return poses

    # ------------------------------------------------------------------ helpers

    def _failed_goal(self, robots: Sequence[int]) -> str:
        """A goal move_base ended other than by reaching it (aborted, rejected, preempted by
        someone else): on real robots a fault that stops the fleet. A stop preempts every goal
        itself: callers give the monitor's reason first (set before the stop cancels anything)."""
        for i in robots:
            result = self.bases[i].result
            if result is not None and not result.succeeded:
                return f"{self.namespaces[i]}: {result.describe()}"
        return ""

    def _aborted(self, goals: Sequence[Optional[int]], t0: Optional[float], reason: str) -> StepOutcome:
        self._lost = reason
        self.trip(reason)
        elapsed = max(0.0, rospy.get_time() - t0) if t0 is not None else 0.0
        robots = [RobotOutcome(has_goal=g is not None, reached=False, nav_time=elapsed if g is not None else 0.0,
                               failure="aborted" if g is not None else "") for g in goals]
        return StepOutcome(robots=robots, aborted=True, abort_reason=reason)

    def _cancel_own(self) -> None:
        """This executor's goals still running, cancelled one by one (a cancel-all could overtake
        the goals sent next on their own connection and cancel them too: only a stop uses it)."""
        cancel_running(self.bases, self.settings.cancel_wait)
        for base in self.bases:
            base.forget()

    def _drive_to_starts(self) -> None:
        """Every robot to its start pose through its move_base, one at a time (`reset_drive`,
        model/fleet.py) or all at once; any failure stops all."""
        if self.real.reset_drive == "one_by_one":
            groups = reset_groups([pose[:2] for pose in self.poses()], [start[:2] for start in self._starts],
                                  footprint_spacing())
        else:
            groups = [list(range(self.n_robots))]
        for group in groups:
            self._drive_group_to_starts(group)
        for base in self.bases:
            base.forget()

    def _drive_group_to_starts(self, group: Sequence[int]) -> None:
        rospy.loginfo("reset: %s driving to %s start pose%s", ", ".join(self.namespaces[i] for i in group),
                      "its" if len(group) == 1 else "their", "" if len(group) == 1 else "s")
        for i in group:
            self.bases[i].send(*self._starts[i])
        deadline = time.monotonic() + self.real.reset_timeout
        while not all(self.bases[i].result is not None for i in group):
            failed = self._failed_goal(group)
            if failed or self.monitor.tripped or time.monotonic() > deadline:
                reason = self.monitor.reason or failed or (
                    "reset: " + ", ".join(self.namespaces[i] for i in group if self.bases[i].result is None)
                    + f" did not reach the start pose within {self.real.reset_timeout:.0f} s of wall time")
                self.trip(reason)
                raise SimulatorLost(reason)   # the manager says "reset failed: "
            if rospy.is_shutdown():
                raise SimulatorLost("node shutting down")
            time.sleep(POLL)
        failed = self._failed_goal(group)
        if failed:
            reason = self.monitor.reason or failed   # a stop ends the goals too: its reason comes first
            self.trip(reason)
            raise SimulatorLost(reason)

    def _await_go(self) -> None:
        if self.real.go:
            return
        self._go.clear()
        self.waiting_for_go = True
        rospy.loginfo("episode ready: waiting for the operator's go (rosservice call %s/go)", rospy.get_name())
        try:
            while not self._go.wait(0.05):
                if self.monitor.tripped:
                    raise SimulatorLost(f"stopped while waiting for the go: {self.monitor.reason}")
                if rospy.is_shutdown():
                    raise SimulatorLost("node shutting down")
        finally:
            self.waiting_for_go = False
