"""The run-time interface of a live fleet on the task manager (docs/reference/nodes_tasks.md,
docs/guide/live_fleet.md): the services `~submit_tasks`, `~cancel_task`, `~robot_leave` and
`~robot_join`, and the latched topic `~fleet_status`.

A thin shell over the ROS-free parts: each request is the environment's own (env/live_fleet.py:
every check and its one-line refusal are there), queued (ros/fleet_requests.py) and applied by the
thread that runs the episode between two decision instants; a waiting request ends the running
transition at the current instant (the environment's and the executor's `interrupted`). While no
episode runs (before a client's ~reset, between the manager's own episodes) a request is refused
at once. The
status (ros/fleet_status.py) is taken in that thread at every instant and after every change, and
published when it changed. Robots the fleet lets go (a request, the scenario's fault) are let go by
the executor too (real robots: drive permit withdrawn, zero cmd_vel); a robot the executor lost
itself (on_robot_fault continue) is reported through `on_robot_fault`.

Which requests an allocator takes: with `replan` all four; with `client` (a policy over ~step,
which decides over the scenario's fixed task set) no submission; cancel, leave and join change
only masks and who decides, which the clients follow.
"""
from __future__ import annotations

import time
from typing import Callable, List, Optional

import rospy

from marl_mrta.msg import FleetStatus
from marl_mrta.srv import (CancelTask, CancelTaskResponse, RobotJoin, RobotJoinResponse, RobotLeave,
                           RobotLeaveResponse, SubmitTasks, SubmitTasksResponse)

from marl_mrta.env.live_fleet import FleetRequestError, TaskRequest
from marl_mrta.model.event_rules import LEFT
from marl_mrta.ros.conversions import snapshot_to_message
from marl_mrta.ros.fleet_requests import FleetRequest, RequestQueue, apply_requests
from marl_mrta.ros.fleet_status import FleetMarks, FleetSnapshot, fleet_snapshot, same_schedule

#: Why the client allocator takes no submission.
CLIENT_SUBMIT = ("allocator client: its policy decides over the scenario's fixed task set; start the task manager "
                 "with allocator:=replan to submit tasks")
#: Why nothing is taken in synchronous mode.
SYNCHRONOUS = "a live fleet needs event mode (decision_mode event)"
#: How often a request's service thread looks whether it may answer (wall s).
POLL = 0.05


class FleetServices:
    """`env`, `executor`: the manager's; `running()`: whether an episode runs (a client's, from its
    ~reset to its end, or the manager's own); `on_change()`: the status changed;
    `on_robot_fault(robot, reason)`: a robot the executor lost (real mode writes it down)."""

    def __init__(self, env, executor, running: Callable[[], bool], allocator: str, request_wait: float,
                 on_change: Callable[[], None] = lambda: None,
                 on_robot_fault: Callable[[int, str], None] = lambda robot, reason: None):
        self.env = env
        self.executor = executor
        self._running = running
        self.allocator = allocator
        self.request_wait = request_wait
        self.on_change = on_change
        self.on_robot_fault = on_robot_fault
        self.live = env.settings.decision_mode == "event"
        self.queue = RequestQueue()
        self.marks = FleetMarks()
        self.latest: Optional[FleetSnapshot] = None
        self.episode = 0
        self._faults_seen = 0
        self.pub_status = rospy.Publisher("~fleet_status", FleetStatus, queue_size=1, latch=True)
        if self.live:
            env.interrupted = executor.interrupted = self.queue.waiting
            executor.instant_listener = self._on_instant
        rospy.Service("~submit_tasks", SubmitTasks, self._on_submit)
        rospy.Service("~cancel_task", CancelTask, self._on_cancel)
        rospy.Service("~robot_leave", RobotLeave, self._on_leave)
        rospy.Service("~robot_join", RobotJoin, self._on_join)

    # ------------------------------------------------------------------ the episode's thread

    def episode_started(self) -> None:
        self.episode += 1
        self.marks.reset()
        self._faults_seen = 0
        self.changed(force=True)

    def apply_waiting(self):
        """Applies the requests that wait (in the episode's thread, between two decision instants);
        returns the output of the last one applied, or None."""
        requests = self.queue.take()
        if not requests:
            return None
        output = apply_requests(self.env, requests, self._running(), self._log_answer)
        self.changed()
        return output

    def changed(self, elapsed: Optional[float] = None, force: bool = False) -> None:
        """After a change (a step, a request, an instant): robots the fleet let go are let go by the
        executor, faults noted, and the status published if it changed."""
        if not self.live:
            return
        if self.env.record is None:   # no episode yet (real robots, allocator replan): an empty schedule
            if force:
                self.latest = FleetSnapshot(False, 0.0, (), ())
                self.pub_status.publish(snapshot_to_message(self.latest, self.allocator, self.episode, rospy.Time.now()))
            return
        rules = self.env.rules
        for robot, state in enumerate(rules.robots):
            if state.phase == LEFT and robot not in self.executor.out_of_fleet:
                self.executor.let_go(robot)
        losses = self.executor.out_of_fleet.losses()
        for robot, reason in losses[self._faults_seen:]:
            self.on_robot_fault(robot, reason)
        self._faults_seen = len(losses)
        self.marks.follow(rules)
        snapshot = fleet_snapshot(self.env, self.executor.poses(), self._running(), self.marks, elapsed)
        if force or not same_schedule(snapshot, self.latest):
            self.latest = snapshot
            self.pub_status.publish(snapshot_to_message(snapshot, self.allocator, self.episode, rospy.Time.now()))
            self.on_change()
        else:
            self.latest = snapshot

    def _on_instant(self, elapsed: float) -> None:
        self.changed(elapsed)

    # ------------------------------------------------------------------ services (rospy's threads)

    def _on_submit(self, request) -> SubmitTasksResponse:
        ids = [t.id for t in request.tasks]
        what = "submit " + ", ".join(ids) if ids else "submit"
        if self.live and self.allocator == "client":
            return SubmitTasksResponse(*self._refused(what, f"submit: {CLIENT_SUBMIT}"))
        tasks = [TaskRequest(t.id, t.category, t.x, t.y, t.yaw, t.service_time, tuple(t.predecessors))
                 for t in request.tasks]
        return SubmitTasksResponse(*self._handle(what, lambda env: env.submit(tasks), "submitted " + ", ".join(ids)))

    def _on_cancel(self, request) -> CancelTaskResponse:
        return CancelTaskResponse(*self._handle(f"cancel {request.id}", lambda env: env.cancel(request.id),
                                                f"cancelled {request.id}"))

    def _on_leave(self, request) -> RobotLeaveResponse:
        reason = request.reason.strip() or "operator"
        return RobotLeaveResponse(*self._handle(f"leave {request.robot}",
                                                lambda env: env.leave(request.robot, reason),
                                                f"{request.robot} left ({reason})"))

    def _on_join(self, request) -> RobotJoinResponse:
        def join(env):
            output = env.join(request.robot)
            self.executor.take_back([r.id for r in env.scenario.robots].index(request.robot))
            return output
        return RobotJoinResponse(*self._handle(f"join {request.robot}", join, f"{request.robot} joined"))

    def _handle(self, what: str, apply, done: str) -> List:
        """[ok, message] of one request, once the episode's thread applied or refused it, or once
        no decision instant came within request_wait (then it is withdrawn, and refused)."""
        if not self.live:
            return self._refused(what, f"{what}: {SYNCHRONOUS}")
        if not self._running():   # no instant will come
            return self._refused(what, f"{what}: no episode is running" + (
                " (call ~reset first)" if self.allocator == "client" else " (the manager's episodes have not started "
                                                                          "or are over)"))
        request = FleetRequest(what, apply, done)
        self.queue.put(request)
        deadline = time.monotonic() + self.request_wait
        while not request.answered.wait(POLL):
            if rospy.is_shutdown():
                self.queue.withdraw(request)
                return self._refused(what, f"{what}: the task manager is shutting down")
            if time.monotonic() > deadline and self.queue.withdraw(request):
                hint = " (the client has not called ~step)" if self.allocator == "client" else ""
                return self._refused(what, f"{what}: not applied: no decision instant came within "
                                           f"{self.request_wait:g} s{hint}")
        return [request.ok, request.message]

    def _refused(self, what: str, message: str) -> List:
        """A refusal the service gives itself: logged, and kept in the running episode's record by
        its thread (a note in the queue that only refuses)."""
        rospy.logwarn("request refused: %s", message)
        if self.live and self._running():
            def refuse(env):
                raise FleetRequestError(message)
            note = FleetRequest(what, refuse, "")
            note.answered.set()   # nobody waits for it
            self.queue.put(note)
        return [False, message]

    @staticmethod
    def _log_answer(request: FleetRequest) -> None:
        if request.ok:
            rospy.loginfo("request: %s", request.message)
        elif request.done_text:   # (a note of the service's own refusal was logged when given)
            rospy.logwarn("request refused: %s", request.message)
