"""The task manager's real-robot side (mode: real, docs/guide/real_robots.md): the operator's services
`~go` and `~estop` (std_srvs/Trigger), the stop on node shutdown (Ctrl-C), and the record of an
aborted episode written to `aborted_episode_file`, so that an episode the client can no longer
receive (Ctrl-C, a lost master) still reaches a file. With on_robot_fault continue, a robot stopped
alone is written there too, with the episode so far (`aborted: false`, `robot_faults`); an abort
later in the episode replaces it.
"""
from __future__ import annotations

import signal
import threading
from dataclasses import replace
from pathlib import Path
from typing import Callable, Optional

import rospy
from std_srvs.srv import Trigger, TriggerResponse

from marl_mrta.common.results import write_result
from marl_mrta.evaluation.summary import episode_rows
from marl_mrta.model.schedule import EpisodeRecord

#: The abort reason of a shutdown: rospy's name of the signal (Ctrl-C: signal-2), else a request.
SHUTDOWN_REASON = "node shutdown ({cause}): operator stop"
#: Wall s the shutdown stop waits for a running step to end (its record is the one written).
SHUTDOWN_WAIT = 3.0


class RealModeServices:
    """`executor`: the RealExecutor; `lock`: the manager's lock (held while a reset or step runs);
    `partial_record()`: the running episode's record so far, or None between episodes."""

    def __init__(self, executor, scenario, lock: threading.Lock,
                 partial_record: Callable[[], Optional[EpisodeRecord]], aborted_file: str):
        self.executor = executor
        self.scenario = scenario
        self.lock = lock
        self.partial_record = partial_record
        self.aborted_file = Path(aborted_file) if aborted_file else None
        self._robot_faults: list = []   # this episode's robots stopped alone: {time, robot, reason}
        rospy.Service("~go", Trigger, self._on_go)
        rospy.Service("~estop", Trigger, self._on_estop)
        # A client shutdown hook runs before rospy closes its topics (its own pre-shutdown hook,
        # registered at init_node, unregisters them first): the stop must still reach the robots.
        rospy.on_shutdown(self._on_shutdown)
        self._signal = ""   # rospy's client hooks get no reason: the signal is noted on its way
        if threading.current_thread() is threading.main_thread():
            for number in (signal.SIGINT, signal.SIGTERM):
                previous = signal.getsignal(number)
                if callable(previous):
                    signal.signal(number, self._noting(previous))

    def _noting(self, previous):
        def handler(number, frame):
            self._signal = self._signal or f"signal-{number}"
            previous(number, frame)
        return handler

    def _on_go(self, _request) -> TriggerResponse:
        if self.executor.give_go():
            rospy.loginfo("operator's go: the episode starts")
            return TriggerResponse(success=True, message="go: the episode starts")
        return TriggerResponse(success=False, message="no episode is waiting for a go (call ~reset first)")

    def _on_estop(self, _request) -> TriggerResponse:
        self.executor.trip("e-stop (~estop)")
        return TriggerResponse(success=True, message=f"stopped: {self.executor.monitor.reason}")

    def _on_shutdown(self) -> None:
        # Stop first, log once it is known whether an episode was cut short (a shutdown between
        # episodes, as at the end of a run, is no fault).
        if self.executor.monitor.tripped:   # stopped before (an abort): the last zero goes out anyway
            self.executor.fleet_stop.stop()
        self.executor.trip(SHUTDOWN_REASON.format(cause=self._signal or "shutdown request"), log=False)
        if not self.lock.acquire(timeout=SHUTDOWN_WAIT):
            rospy.logerr("shutdown: the running step did not end within %.0f s; its record is lost", SHUTDOWN_WAIT)
            return
        try:
            record = self.partial_record()   # between steps: the episode so far
            if record is not None:
                rospy.logerr("safe stop: %s: every goal cancelled, zero cmd_vel sent to %s",
                             self.executor.monitor.reason, ", ".join(self.executor.namespaces))
                self.write_aborted(replace(record, truncated=True, complete=False,
                                           abort_reason=self.executor.monitor.reason))
            else:
                rospy.loginfo("shutdown: every goal cancelled, every robot sent zero cmd_vel")
        finally:
            self.lock.release()
        # rospy closes its connections when this hook returns: the held stop goes out first.
        self.executor.fleet_stop.wait_hold(self.executor.real.stop_hold + 0.5)

    def write_aborted(self, record: EpisodeRecord) -> None:
        """The aborted episode's record as a result document (docs/guide/real_robots.md)."""
        if self.aborted_file is None:
            return
        document = {"scenario": str(self.scenario.source), "scenario_name": self.scenario.name, "executor": "ros",
                    "mode": "real", "aborted": True, "abort_reason": record.abort_reason,
                    "episodes": episode_rows([record]), "episode": record.to_dict()}
        write_result(self.aborted_file, document)
        rospy.logerr("episode aborted (%s): its record is in %s", record.abort_reason, self.aborted_file)

    def episode_started(self) -> None:
        self._robot_faults = []

    def write_robot_fault(self, record: EpisodeRecord, robot: str, reason: str) -> None:
        """A robot stopped alone (on_robot_fault continue): the episode so far and every robot fault
        of it, in the same file; the episode goes on."""
        self._robot_faults.append({"time": record.makespan, "robot": robot, "reason": reason})
        if self.aborted_file is None:
            return
        document = {"scenario": str(self.scenario.source), "scenario_name": self.scenario.name, "executor": "ros",
                    "mode": "real", "aborted": False, "robot_faults": list(self._robot_faults),
                    "episode": record.to_dict()}
        write_result(self.aborted_file, document)
        rospy.logerr("robot fault written to %s: %s", self.aborted_file, reason)
