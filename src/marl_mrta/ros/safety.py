"""The safety rules of real robots, without ROS: when the fleet must stop, and why.

The real executor (ros/real_executor.py) reports to a SafetyMonitor every message it hears from
each robot (odometry, scan, move_base status), how well each scan fits the map where
localisation puts the robot (model/scan_fit.py), and every answer or failure of the ROS master,
and asks it, several times a second, whether to stop. Once tripped, the monitor keeps its first
reason until it is re-armed (a new episode's reset), so a stop is never undone by a robot that
comes back. Faults from elsewhere (an e-stop, the node shutting down, a move_base goal that
aborted) trip it directly. Times are seconds of a monotonic wall clock.

A fault concerns one robot (its odometry, scan or move_base silent, its localisation lost) or the
fleet (the master lost, and the trips from elsewhere). With `on_robot_fault: continue` the executor
stops a robot with a fault of its own alone, and `excuse()`s it: a robot out of the fleet is no
longer watched, until it joins again (`watch_again`) or the next episode.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Set, Tuple

#: What the monitor hears from each robot, and what each part is called in a reason.
PARTS = ("odom", "scan", "move_base")


@dataclass(frozen=True)
class SafetyLimits:
    """How long each part may stay silent, and the master unreachable, before the fleet stops [s];
    how well a robot's scan must fit the map, and for how long it may fit worse."""

    odom_silent_after: float = 1.0       # turtlebot3_core publishes odometry at 30 Hz
    scan_silent_after: float = 1.0       # the LDS-01 turns at 5 Hz
    move_base_silent_after: float = 2.0  # move_base publishes its action status at 5 Hz
    master_lost_after: float = 1.0       # the ROS master does not answer for this long (a loaded PC stalls it 0.5 s)
    scan_fit_min: float = 0.5            # share of a scan's returns near the map's obstacles; 0: not watched
    scan_fit_lost_scans: int = 10        # judged scans in a row below scan_fit_min (2 s of LDS-01) that mean lost
    scan_fit_tolerance: float = 0.2      # m from an occupied cell that a return may end and still fit
    scan_fit_max_turn: float = 1.0       # rad/s: scans taken while the robot turns faster are not judged

    def silent_after(self, part: str) -> float:
        return {"odom": self.odom_silent_after, "scan": self.scan_silent_after,
                "move_base": self.move_base_silent_after}[part]


class SafetyMonitor:
    """The fleet's stop decision. Thread-safe: callbacks report, a watchdog thread checks."""

    def __init__(self, robots: Sequence[str], limits: SafetyLimits):
        self.robots = list(robots)
        self.limits = limits
        self._lock = threading.Lock()
        self._heard: Dict[Tuple[int, str], float] = {}
        self._master_ok: Optional[float] = None      # last answer of the master
        self._master_error = ""
        self._reason = ""
        self._tripped_at: Optional[float] = None
        self._armed_at: Optional[float] = None        # silence counts from here at the earliest
        # robot -> (first, count, latest) of its bad fits in a row
        self._unfit: Dict[int, Tuple[float, int, float]] = {}
        self._excused: Set[int] = set()               # robots out of the fleet: not watched

    # ------------------------------------------------------------------ reports
    def heard(self, robot: int, part: str, now: float) -> None:
        with self._lock:
            self._heard[(robot, part)] = now

    def fitted(self, robot: int, fit: Optional[float], now: float) -> None:
        """The fit of the robot's latest scan at its estimated pose (None: not judged, neither
        good nor bad: too few returns, or the robot turned fast)."""
        if fit is None:
            return
        with self._lock:
            if fit >= self.limits.scan_fit_min:
                self._unfit.pop(robot, None)
            else:
                first, count, _ = self._unfit.get(robot, (now, 0, fit))
                self._unfit[robot] = (first, count + 1, fit)

    def master_answered(self, now: float) -> None:
        with self._lock:
            self._master_ok, self._master_error = now, ""

    def master_failed(self, error: str) -> None:
        with self._lock:
            self._master_error = error

    # ------------------------------------------------------------------ decisions
    def missing(self) -> List[str]:
        """"<robot> <part>" for every part not heard from yet (start-up)."""
        with self._lock:
            return [f"{ns} {part}" for i, ns in enumerate(self.robots) for part in PARTS if (i, part) not in self._heard]

    def fault(self, now: float) -> str:
        """Why the fleet must stop now ("" when nothing is wrong): the first robot's fault, else the
        fleet's. Parts never heard count from the arming time (start-up has its own wait, missing())."""
        robots = self.robot_faults(now)
        return robots[0][1] if robots else self.fleet_fault(now)

    def robot_faults(self, now: float) -> List[Tuple[int, str]]:
        """(robot, reason) of every robot in the fleet with a fault of its own, in robot order."""
        with self._lock:
            return [(i, reason) for i in range(len(self.robots)) if i not in self._excused
                    for reason in [self._robot_fault(i, now)] if reason]

    def fleet_fault(self, now: float) -> str:
        """A fault that concerns every robot ("" when none): the ROS master unreachable."""
        with self._lock:
            if self._master_ok is not None and now - self._master_ok > self.limits.master_lost_after:
                detail = f" ({self._master_error})" if self._master_error else ""
                return f"ROS master unreachable for {now - self._master_ok:.1f} s{detail}"
        return ""

    def _robot_fault(self, i: int, now: float) -> str:
        ns = self.robots[i]
        for part in PARTS:
            last = self._heard.get((i, part), self._armed_at)
            if last is None:
                continue
            silent = now - last
            if silent > self.limits.silent_after(part):
                return f"{ns}: {part} silent for {silent:.1f} s"
        first, count, fit = self._unfit.get(i, (now, 0, 1.0))
        if count >= self.limits.scan_fit_lost_scans:
            return (f"{ns}: localisation lost: its last {count} scans fit the map at the estimated pose below "
                    f"{self.limits.scan_fit_min * 100:.0f} % ({now - first:.1f} s, the latest "
                    f"{fit * 100:.0f} %)")
        return ""

    def excuse(self, robot: int) -> None:
        """The robot is out of the fleet: its silence no longer counts."""
        with self._lock:
            self._excused.add(robot)
            self._unfit.pop(robot, None)

    def watch_again(self, robot: int) -> None:
        """The robot is back in the fleet: watched again from what was last heard of it."""
        with self._lock:
            self._excused.discard(robot)

    def check(self, now: float) -> str:
        """Trips on a fault; returns the reason the fleet is stopped ("" while it may drive)."""
        if not self.tripped:
            reason = self.fault(now)
            if reason:
                self.trip(reason, now)
        return self.reason

    def trip(self, reason: str, now: float) -> bool:
        """Stops the fleet for `reason`; False when it was already stopped (the first reason stays)."""
        with self._lock:
            if self._reason:
                return False
            self._reason, self._tripped_at = reason, now
            return True

    def rearm(self, now: float) -> str:
        """Clears a stop (a new episode) unless a fault persists; returns that fault or ""."""
        with self._lock:
            self._reason, self._tripped_at, self._armed_at = "", None, now
            self._excused.clear()
        return self.check(now)

    @property
    def tripped(self) -> bool:
        with self._lock:
            return bool(self._reason)

    @property
    def reason(self) -> str:
        with self._lock:
            return self._reason

    @property
    def tripped_at(self) -> Optional[float]:
        with self._lock:
            return self._tripped_at


def hold_times(start: float, hold: float, period: float) -> List[float]:
    """When to send the zero command of a stop: at once, then every `period` s for `hold` s, so
    that a command a navigation node had in flight cannot outlast it."""
    if hold <= 0.0 or period <= 0.0:
        return [start]
    count = int(math.floor(hold / period + 1e-9))
    return [start + k * period for k in range(count + 1)]


class VelocityGate:
    """Whether a robot's navigation may drive it (the cmd_vel gate between move_base and the
    base, apps/cmd_vel_gate_node.py). Open only while the task manager's latest drive permit said
    yes and is at most `permit_timeout` s old: a stop withdraws it, and a manager that is gone
    stops sending it. Stock move_base's rotate_recovery publishes its own commands until its turn
    ends, whatever the cancel; behind the gate they never reach the wheels. Times are seconds of
    a monotonic clock."""

    def __init__(self, permit_timeout: float):
        if not permit_timeout > 0.0:
            raise ValueError(f"permit_timeout: must be > 0, got {permit_timeout!r}")
        self.permit_timeout = permit_timeout
        self._permit: Optional[bool] = None
        self._permit_at: Optional[float] = None
        self._open = False
        self._reason = "no drive permit yet"

    def permit(self, allowed: bool, now: float) -> None:
        self._permit, self._permit_at = bool(allowed), now

    def update(self, now: float) -> Tuple[bool, str]:
        """(open, changed reason): the reason is "" unless the gate just closed or opened, then
        why (closing) or "open" (opening), once per change."""
        if self._permit_at is None:
            should_open, why = False, "no drive permit yet"
        elif now - self._permit_at > self.permit_timeout:
            should_open, why = False, f"no drive permit for {now - self._permit_at:.1f} s (the task manager is gone or hangs)"
        elif not self._permit:
            should_open, why = False, "drive permit withdrawn (the fleet is stopped)"
        else:
            should_open, why = True, "open"
        changed = should_open != self._open
        self._open = should_open
        if not should_open:
            self._reason = why
        return should_open, why if changed else ""

    @property
    def is_open(self) -> bool:
        return self._open

    @property
    def permit_withdrawn(self) -> bool:
        """The latest permit said no (as against: none yet, or none for too long)."""
        return self._permit is False

    @property
    def reason(self) -> str:
        """Why the gate is closed ("" while open)."""
        return "" if self._open else self._reason
