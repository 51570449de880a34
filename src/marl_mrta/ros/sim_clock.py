"""Waiting on the simulator without ever hanging on a simulator that is gone.

Two kinds of wait: on sim time (/clock) while robots drive, with a wall-clock watchdog on its
progress, and on a condition in wall time (an answer that must come within a bound).
"""
from __future__ import annotations

import threading
import time
from typing import Callable, Optional, TypeVar, Union

import rospy

T = TypeVar("T")


class SimulatorLost(RuntimeError):
    """The simulator, or a node it waits on, stopped answering; str(error) says which and why."""


class SimClock:
    """Sim time as seen through /clock, with a wall-clock watchdog on its progress.

    In lock-step the simulator only advances when every controller has answered, so a dead
    move_base stalls /clock just like a dead simulator: both end the wait with SimulatorLost;
    `diagnose()` (optional) names the culprit in the message. `on_stall()` (optional) is asked
    first: True when it removed the cause (a robot whose move_base is gone let out of the
    lock-step, on_robot_fault continue), and the wait goes on.
    """

    def __init__(self, lost_after_wall: float, poll_wall: float = 0.002,
                 diagnose: Optional[Callable[[], str]] = None, on_stall: Optional[Callable[[], bool]] = None):
        self.lost_after_wall = lost_after_wall
        self.poll_wall = poll_wall
        self.diagnose = diagnose
        self.on_stall = on_stall

    def now(self) -> float:
        return rospy.get_time()

    def wait_until(self, predicate: Callable[[], bool], deadline_sim: float = float("inf")) -> bool:
        """Polls `predicate()` until true (returns True) or sim time reaches `deadline_sim`
        (returns False). Raises SimulatorLost when sim time stops for `lost_after_wall` s."""
        last_sim = self.now()
        last_progress_wall = time.monotonic()
        while not rospy.is_shutdown():
            if predicate():
                return True
            sim_now = self.now()
            if sim_now >= deadline_sim - 1e-9:   # a tick's stamp may round just below the sum
                return False
            if sim_now != last_sim:
                last_sim, last_progress_wall = sim_now, time.monotonic()
            elif time.monotonic() - last_progress_wall > self.lost_after_wall:
                if self.on_stall is not None and self.on_stall():
                    last_progress_wall = time.monotonic()
                    continue
                detail = self.diagnose() if self.diagnose else ""
                raise SimulatorLost(f"no /clock progress for {self.lost_after_wall:.1f} s of wall time at sim time "
                                    f"{sim_now:.2f} s" + (f" ({detail})" if detail else ""))
            time.sleep(self.poll_wall)
        raise SimulatorLost("node shutting down")


def wait_wall(predicate: Callable[[], bool], timeout_wall: float, what: Union[str, Callable[[], str]],
              poll_wall: float = 0.002) -> None:
    """Polls `predicate()` in wall time; raises SimulatorLost naming `what` (a text, or a function
    giving it when the time is up) after `timeout_wall` s."""
    deadline = time.monotonic() + timeout_wall
    while not predicate():
        if rospy.is_shutdown():
            raise SimulatorLost("node shutting down")
        if time.monotonic() > deadline:
            text = what() if callable(what) else what
            raise SimulatorLost(f"{text} within {timeout_wall:.1f} s of wall time")
        time.sleep(poll_wall)


def call_bounded(call: Callable[[], T], timeout_wall: float, what: str) -> T:
    """Runs a blocking ROS call (a service call has no timeout of its own) with a wall bound.

    A call that does not return in time is left to finish in its daemon thread; the caller
    gets SimulatorLost instead of hanging with it.
    """
    box: dict = {}

    def run() -> None:
        try:
            box["value"] = call()
        except Exception as error:  # noqa: BLE001 - handed over to the caller's thread
            box["error"] = error

    worker = threading.Thread(target=run, daemon=True, name=what)
    worker.start()
    worker.join(timeout_wall)
    if worker.is_alive():
        raise SimulatorLost(f"{what}: no answer within {timeout_wall:.1f} s of wall time")
    if "error" in box:
        error = box["error"]
        if isinstance(error, (rospy.ServiceException, rospy.ROSException, OSError)):
            raise SimulatorLost(f"{what}: {error}") from None
        raise error
    return box["value"]
