"""One robot driven leg by leg through whatever move_base runs (stock or built-in), in a simulator
that runs freely (no lock-step, e.g. real time): the harness that holds the built-in navigation
against the stock stack (apps/bench_nav_vs_stock.py, evaluation/nav_comparison.py).

Per leg: the goal of the last leg cancelled, the robot reset to the leg's start with the leg's
noise seed, both costmaps cleared, sim time run for the scans to refill them; with a particle
filter, `initialpose` at the start and sim time until its estimate agrees (as the task manager
does on every reset); then the goal, and its result or the timeout. Recorded: outcome, sim time
from goal to result, path length and, with a filter, its estimates against the ground truth and
the CPU time its node used meanwhile (/proc).
"""
from __future__ import annotations

import math
import os
import xmlrpc.client
from typing import Optional

import rosgraph
import rospy
from std_srvs.srv import Empty

from marl_mrta.evaluation.nav_comparison import (STALE_SUCCESS_WITHIN, Leg, LegRecord, LegTimings, LocalisationFigures,
                                                 is_stale_success, path_length, pose_at)
from marl_mrta.ros.graph_probe import GraphProbe
from marl_mrta.ros.localization_link import LocalizationLink
from marl_mrta.ros.move_base_link import MoveBaseLink
from marl_mrta.ros.sim_clock import SimClock, SimulatorLost, call_bounded, wait_wall
from marl_mrta.ros.sim_link import SimulatorLink

CLOCK_TICKS = os.sysconf("SC_CLK_TCK")
#: s of sim time after a reset for the lidar (5 Hz) to refill the cleared costmaps.
REFILL = 1.0
#: s of sim time between requests for an update without motion while the filter has not answered.
NOMOTION_PERIOD = 0.2


def process_cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a process and all its threads so far."""
    with open(f"/proc/{pid}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def node_pid(node: str, caller: str) -> Optional[int]:
    """The process id of a ROS node (None when it is not registered or does not answer)."""
    try:
        return int(xmlrpc.client.ServerProxy(rosgraph.Master(caller).lookupNode(node)).getPid(caller)[2])
    except (OSError, xmlrpc.client.Error, rosgraph.MasterError, ValueError, TypeError):
        return None


class LegRunner:
    """Drives the legs of one robot (`namespace`, no leading slash) and records each."""

    def __init__(self, namespace: str, localization: bool, timings: LegTimings = LegTimings()):
        self.namespace = namespace
        self.timings = timings
        self.sim = SimulatorLink([namespace], 0, timings.answer_wall)
        self.base = MoveBaseLink("/" + namespace, "map")
        self.localizer = LocalizationLink("/" + namespace, "map") if localization else None
        self.probe = GraphProbe([namespace])
        self.clock = SimClock(timings.answer_wall)
        self._clear = rospy.ServiceProxy(f"/{namespace}/move_base/clear_costmaps", Empty)
        self._filter_pid: Optional[int] = None

    def wait_ready(self, timeout_wall: float) -> None:
        self.sim.wait_ready(timeout_wall)
        wait_wall(self.base.connected, timeout_wall, f"/{self.namespace}/move_base did not connect")
        self._clear.wait_for_service(timeout_wall)
        if self.localizer is not None:
            wait_wall(self.localizer.connected, timeout_wall, f"/{self.namespace}/amcl did not take initialpose")
            self._filter_pid = node_pid(f"/{self.namespace}/amcl", rospy.get_name())
            if self._filter_pid is None:
                raise SimulatorLost(f"/{self.namespace}/amcl: no process id from the master")

    def drive(self, index: int, leg: Leg) -> LegRecord:
        self._prepare(leg)
        cpu0 = self._filter_cpu()
        t0 = self.clock.now()
        t1, succeeded, outcome = self._goal(leg, t0)
        resent = 0
        # A stale success of stock move_base (ros-planning/navigation#949): the goal once more.
        if (succeeded and t1 - t0 <= STALE_SUCCESS_WITHIN
                and is_stale_success(succeeded, t1 - t0, self._distance_to(leg.goal, t1))):
            resent = 1
            rospy.logwarn("leg %d: reported reached %.2f s after the goal, away from it "
                          "(ros-planning/navigation#949): sent again", index, t1 - t0)
            t1, succeeded, outcome = self._goal(leg, t0)
        self._stop()
        cpu = self._filter_cpu() - cpu0
        # The ground truth up to the end has arrived once sim time is past it.
        self.clock.wait_until(lambda: self.clock.now() > t1 + 0.2)
        records = self.probe.snapshot()[self.namespace]
        track = records["ground_truth"]
        estimates = [e for e in records["amcl_pose"] if t0 - 1e-9 <= e[0] <= t1 + 1e-9]
        return LegRecord(index=index, succeeded=succeeded, outcome=outcome, time=t1 - t0,
                         path_length=path_length(track, t0, t1),
                         collisions=sum(self.sim.collisions_between(t0, t1)),
                         localisation=LocalisationFigures.of(estimates, track) if self.localizer else None,
                         filter_cpu=cpu, filter_updates=len(estimates) if self.localizer else 0, resent=resent)

    # ------------------------------------------------------------------ helpers

    def _goal(self, leg: Leg, t0: float):
        """Sends the leg's goal; (end, succeeded, outcome) by its result or the timeout from t0."""
        self.base.send(*leg.goal)
        wait_wall(lambda: self.base.accepted, self.timings.answer_wall,
                  f"/{self.namespace}/move_base did not take the goal")
        if self.clock.wait_until(lambda: self.base.result is not None, t0 + self.timings.goal_timeout):
            result = self.base.result
            return max(result.stamp, t0), result.succeeded, result.describe()
        timeout = self.timings.goal_timeout
        return t0 + timeout, False, f"timeout after {timeout:g} s"

    def _distance_to(self, goal, t: float) -> Optional[float]:
        """m from the robot's true position at sim time t (once it has arrived) to the goal."""
        self.clock.wait_until(lambda: self.clock.now() > t + 0.1)
        pose = pose_at(self.probe.snapshot()[self.namespace]["ground_truth"], t)
        return None if pose is None else math.hypot(pose[0] - goal[0], pose[1] - goal[1])

    def _stop(self) -> None:
        """No goal running and the robot's last command given (move_base stops it on cancel)."""
        if not self.base.idle:
            self.base.cancel()
            wait_wall(lambda: self.base.idle, self.timings.answer_wall,
                      f"/{self.namespace}/move_base did not confirm a cancel")

    def _prepare(self, leg: Leg) -> None:
        self._stop()
        self.base.forget()
        # A command still on its way after the cancel would move the reset robot: let it pass.
        self._run_for(0.3)
        self.sim.reset([leg.start], leg.noise_seed)
        call_bounded(self._clear, self.timings.answer_wall, self._clear.resolved_name)
        self._run_for(REFILL)
        if self.localizer is not None:
            self._relocalise(leg.start)

    def _run_for(self, seconds: float) -> None:
        until = self.clock.now() + seconds
        self.clock.wait_until(lambda: self.clock.now() >= until)

    def _relocalise(self, start) -> None:
        """initialpose at the reset pose, then sim time until the filter's estimate agrees with it
        (asking for updates without motion while it has none), then its transform's tolerance."""
        self.localizer.reinitialise(start)
        deadline = self.clock.now() + self.timings.localization_wait
        next_request = self.clock.now()
        while True:
            error = self.localizer.error_to(start)
            tolerance = self.timings.localization_tolerance
            if error is not None and error[0] <= tolerance and error[1] <= tolerance:
                self._run_for(self.timings.localization_settle)
                return
            now = self.clock.now()
            if now >= deadline:
                where = "no estimate" if error is None else f"{error[0]:.2f} m / {error[1]:.2f} rad off"
                raise SimulatorLost(f"/{self.namespace}/amcl: {where} {self.timings.localization_wait:g} s after the reset")
            if error is None and now >= next_request:
                self.localizer.request_update()
                next_request = now + NOMOTION_PERIOD
            self._run_for(0.05)

    def _filter_cpu(self) -> float:
        if self._filter_pid is None:
            return 0.0
        try:
            return process_cpu_seconds(self._filter_pid)
        except OSError:
            raise SimulatorLost(f"/{self.namespace}/amcl (process {self._filter_pid}) is gone") from None

