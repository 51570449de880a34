"""Run-time requests of a live fleet, queued until the episode can take them, ROS-free.

The task manager's services (ros/fleet_services.py) run in rospy's threads while the episode runs
in another (a client's ~step, or the manager's own loop with the replanning allocator). A request
is queued; the thread that runs the episode takes the queue between two decision instants (its
environment's `interrupted` is `RequestQueue.waiting`: a waiting request ends the transition at the
current instant) and applies each request in order (`apply_requests`), so the environment only
ever changes in that thread. Each request is answered once: applied, refused (the environment's
FleetRequestError, one line), or withdrawn by its service when no instant came in time.
"""
from __future__ import annotations

import threading
from dataclasses import replace
from typing import Any, Callable, List, Optional

from marl_mrta.env.live_fleet import FleetRequestError


class FleetRequest:
    """One request: `what` names it ("cancel B3"), `apply(env)` changes the environment and returns
    its output to decide on, `done` (one line) says what it did."""

    def __init__(self, what: str, apply: Callable[[Any], Any], done: str):
        self.what = what
        self.apply = apply
        self.done_text = done
        self.answered = threading.Event()
        self.ok = False
        self.message = ""
        self.applied_at: Optional[float] = None   # s since the episode's start

    def answer(self, ok: bool, message: str) -> None:
        self.ok, self.message = ok, message
        self.answered.set()


class RequestQueue:
    """Requests in arrival order; thread-safe."""

    def __init__(self):
        self._lock = threading.Lock()
        self._pending: List[FleetRequest] = []

    def put(self, request: FleetRequest) -> None:
        with self._lock:
            self._pending.append(request)

    def waiting(self) -> bool:
        """A request waits (the environment's and the executor's `interrupted`)."""
        with self._lock:
            return bool(self._pending)

    def take(self) -> List[FleetRequest]:
        with self._lock:
            taken, self._pending = self._pending, []
        return taken

    def withdraw(self, request: FleetRequest) -> bool:
        """Drops a request not taken yet; False when it was (it is being applied or was)."""
        with self._lock:
            if request in self._pending:
                self._pending.remove(request)
                return True
        return False


def apply_requests(env, requests: List[FleetRequest], running: bool,
                   on_answer: Callable[[FleetRequest], None] = lambda request: None) -> Optional[Any]:
    """Applies `requests` in order to `env` (in the thread that runs its episode); returns the output
    of the last one applied (None: none was). A refused request changes nothing, is kept in the
    record when an episode runs (`running`), and is answered with the environment's one line."""
    latest = None
    for request in requests:
        try:
            latest = request.apply(env)
        except FleetRequestError as refusal:
            if running:
                env.refuse(request.what, str(refusal))
            request.answer(False, str(refusal))
        else:
            request.applied_at = float(env.elapsed)
            request.answer(True, f"{request.done_text} at {env.elapsed:.2f} s")
        on_answer(request)
    return latest


def merged_output(transition, after):
    """The output of a transition that requests ended (a StepOutput): its rewards and what happened
    in it, with the fleet as it stands after the requests (observations, masks, who decides next,
    each robot's task), so that a client decides on the fleet as it is."""
    info = replace(transition.info, finished=list(after.info.finished), robot_tasks=list(after.info.robot_tasks))
    return replace(after, rewards=transition.rewards, reward_components=transition.reward_components, info=info)
