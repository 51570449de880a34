"""The task rules of event mode: a robot decides when it comes free, while the others keep driving.

The state machine of one episode's tasks and robots, shared by the environment (env/event_env.py)
over any executor and by the planners' check of their fast schedule (baselines/plan.py).
Times are absolute (s from the episode's start); the executor says when a leg ends, these rules
say everything else:

- A robot is `idle` (no task, or chose None), `driving` to a task, `holding` at a task whose
  predecessors are not all finished, or `serving` it (its service time).
- A leg that reaches its task: the task is already finished or taken by a robot standing at it
  (holding or serving) -> a wasted trip, the robot is free; else its predecessors are finished ->
  service starts; else the robot holds there and serves it from its last predecessor's finish.
  No task is ever done out of order. A leg that fails frees the robot where it stands.
- A service end finishes the task (first arrival serves it: never a double finish) and frees its
  robot; held successors whose last predecessor that was start their service at that instant.
- A robot gets a decision (`due`) when: it finishes its task; its leg fails or is wasted; it is
  idle and a task becomes ready (its last predecessor finished); and at the episode's start. When
  no robot drives or serves (nothing can change by itself), every idle or holding robot gets one
  `min_step` after the last event, so that an episode never stalls: a holding robot may stay
  (choosing its task again) or leave.
- Robots due at the same instant decide together (the environment takes their actions at once;
  a policy may decide them in turn with claims).

A live fleet (env/live_fleet.py) changes while it works:
- A task may be unknown until its release (`known`), and tasks may be added: an unknown task is
  no robot's to choose.
- Every change of the fleet (a release, a task added or cancelled, a robot leaving or joining)
  makes the idle and the holding robots due: the allocation may change for all who stand (a
  holding robot may keep its task, or leave it for another).
- A cancelled task is never started: a robot driving to it or holding at it is freed (due), a
  task in service cannot be cancelled, and its successors wait for its own predecessors instead
  (the precedence among the other tasks is kept).
- A robot that leaves (`left`) never decides again; the task it drove to, held or served returns
  to the pool unfinished (its successors wait for it) and idle robots decide. A robot that joins
  is idle and due.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

IDLE, DRIVING, HOLDING, SERVING, LEFT = "idle", "driving", "holding", "serving", "left"
#: s: events within this of each other are one instant (floating sums of leg times).
SAME_INSTANT = 1e-9


@dataclass
class RobotState:
    phase: str = IDLE
    task: Optional[int] = None       # the task it drives to, holds at or serves (None when idle)
    since: float = 0.0               # when the current phase began
    leg_start: float = 0.0           # when its current (or last) leg began
    service_end: float = 0.0         # serving: when the service ends
    decided_at: float = 0.0          # its last decision


@dataclass
class Attempt:
    """A robot's try at a task, from its decision to its end: what the reward and record need."""

    robot: int
    task: int
    decided_at: float
    arrived_at: Optional[float] = None   # None: the leg failed
    nav_time: float = 0.0                # s driven (to arrival or failure)
    held: float = 0.0                    # s waited at the task for predecessors
    service_start: Optional[float] = None
    finish_time: Optional[float] = None  # its finish (service end), None if it finished nothing
    failure: str = ""                    # why the leg failed ("" if it arrived)
    wasted: bool = False                 # arrived at a task already finished or taken


@dataclass
class EventOutcome:
    """What happened between two decision instants (a transition), per robot where indexed."""

    time: float
    ended: List[Attempt] = field(default_factory=list)        # attempts that ended (finished, failed, wasted)
    finished: List[Tuple[int, int, float]] = field(default_factory=list)   # (task, robot, finish time) in order
    released: List[int] = field(default_factory=list)         # tasks that became ready


class EventRules:
    """One episode of event-mode rules; see the module docstring."""

    def __init__(self, n_robots: int, predecessors: Sequence[Sequence[int]], service_times: Sequence[float],
                 min_step: float, known: Optional[Sequence[bool]] = None):
        self.n_robots = n_robots
        self._initial = ([tuple(p) for p in predecessors], list(service_times),
                         [True] * len(service_times) if known is None else [bool(k) for k in known])
        self.min_step = min_step
        self.reset()

    def reset(self, now: float = 0.0) -> None:
        """The episode's start: the initial tasks (added ones dropped), every robot idle and due."""
        predecessors, service, known = self._initial
        n_tasks = len(service)
        self.predecessors = list(predecessors)
        self.successors: List[List[int]] = [[] for _ in predecessors]
        for task, preds in enumerate(self.predecessors):
            for p in preds:
                self.successors[p].append(task)
        self.service = list(service)
        self.known = list(known)
        self.cancelled = [False] * n_tasks
        self.robots = [RobotState(since=now, decided_at=now) for _ in range(self.n_robots)]
        self.finished = [False] * n_tasks
        self.finish_time: List[Optional[float]] = [None] * n_tasks
        self.finished_by: List[Optional[int]] = [None] * n_tasks
        self.attempts: List[Optional[Attempt]] = [None] * self.n_robots
        self.due = set(range(self.n_robots))
        self.last_event = now

    # ------------------------------------------------------------------ questions

    def ready(self, task: int) -> bool:
        return self.open(task) and all(self.finished[p] for p in self.predecessors[task])

    def open(self, task: int) -> bool:
        """Known, neither finished nor cancelled: a task some robot may still take."""
        return self.known[task] and not self.finished[task] and not self.cancelled[task]

    def closed(self, task: int) -> bool:
        """Finished or cancelled: nothing more happens to it."""
        return self.finished[task] or self.cancelled[task]

    def present(self, robot: int) -> bool:
        return self.robots[robot].phase != LEFT

    def taken(self, task: int, by_other_than: Optional[int] = None) -> bool:
        """A robot other than `by_other_than` drives to, holds at or serves the task."""
        return any(r.task == task and i != by_other_than for i, r in enumerate(self.robots)
                   if r.phase not in (IDLE, LEFT))

    def occupied(self, task: int) -> bool:
        """A robot stands at the task (holding or serving)."""
        return any(r.task == task and r.phase in (HOLDING, SERVING) for r in self.robots)

    def running(self) -> bool:
        """Something changes by itself: a robot drives or serves."""
        return any(r.phase in (DRIVING, SERVING) for r in self.robots)

    @property
    def n_tasks(self) -> int:
        return len(self.service)

    @property
    def done(self) -> bool:
        """Every task finished or cancelled (an unknown one is neither)."""
        return all(f or c for f, c in zip(self.finished, self.cancelled))

    def _may_wake(self) -> bool:
        """Nothing runs, no robot is due, and a robot could act: one holds, or one is idle while
        some task is open (with none open, nothing changes until a task is released or added)."""
        if self.running() or self.due:
            return False
        if any(r.phase == HOLDING for r in self.robots):
            return True
        return any(r.phase == IDLE for r in self.robots) and any(self.open(j) for j in range(self.n_tasks))

    def next_timer(self) -> Optional[float]:
        """The next time the rules themselves act: a service end, or the min_step wake-up when
        nothing runs and no robot is due."""
        ends = [r.service_end for r in self.robots if r.phase == SERVING]
        if ends:
            return min(ends)
        if self._may_wake():
            return self.last_event + self.min_step
        return None

    # ------------------------------------------------------------------ changes

    def assign(self, robot: int, task: Optional[int], now: float) -> None:
        """A due robot's decision: drive to `task`, or (None) stay idle. A holding robot that chooses
        its own task again keeps holding."""
        state = self.robots[robot]
        self.due.discard(robot)
        state.decided_at = now
        if task is not None and state.phase == HOLDING and state.task == task:
            return
        if state.phase == HOLDING:   # it leaves: its attempt ends unserved
            attempt = self.attempts[robot]
            if attempt is not None:
                attempt.held = now - state.since
            self.attempts[robot] = None
        if task is None:
            state.phase, state.task, state.since = IDLE, None, now
            return
        state.phase, state.task, state.since, state.leg_start = DRIVING, task, now, now
        self.attempts[robot] = Attempt(robot, task, now)

    def leg_ended(self, robot: int, now: float, reached: bool, failure: str = "") -> Optional[Attempt]:
        """The executor's report: the robot's leg reached its task at `now`, or failed. Returns the
        attempt if it ended here (failed or wasted)."""
        state = self.robots[robot]
        if state.phase != DRIVING:
            raise ValueError(f"robot {robot}: a leg ended while it was {state.phase}")
        attempt = self.attempts[robot]
        task = state.task
        attempt.nav_time = now - state.leg_start
        if not reached:
            attempt.failure = failure or "failed"
            return self._free(robot, now)
        attempt.arrived_at = now
        if not self.open(task) or self.occupied(task):
            attempt.wasted = True
            return self._free(robot, now)
        if all(self.finished[p] for p in self.predecessors[task]):
            self._serve(robot, now)
        else:
            state.phase, state.since = HOLDING, now
        return None

    def advance_to(self, now: float, outcome: EventOutcome) -> None:
        """Service ends up to `now`, in time order (each releasing held successors at its instant),
        and the min_step wake-up; adds what happened to `outcome`."""
        while True:
            serving = [(r.service_end, i) for i, r in enumerate(self.robots) if r.phase == SERVING]
            if not serving:
                break
            end, robot = min(serving)
            if end > now + SAME_INSTANT:
                break
            self._finish(robot, end, outcome)
        if self._may_wake() and now >= self.last_event + self.min_step - SAME_INSTANT:
            self.due.update(i for i, r in enumerate(self.robots) if r.phase in (IDLE, HOLDING))
        if outcome.ended or outcome.finished or self.due:
            self.last_event = now

    def resume(self, now: float, finished: Sequence[bool], at_task: Dict[int, int]) -> None:
        """An episode taken up midway: `finished` tasks done (at unknown times, so `now`), and the
        robots of `at_task` standing at those tasks since `now` (serving them, or holding for their
        predecessors); every other robot idle and due."""
        self.reset(now)
        for task, done in enumerate(finished):
            if done:
                self.finished[task], self.finish_time[task] = True, now
        for robot, task in at_task.items():
            state = self.robots[robot]
            state.task, state.leg_start = task, now
            self.attempts[robot] = Attempt(robot, task, now, arrived_at=now)
            self.due.discard(robot)
            if all(self.finished[p] for p in self.predecessors[task]):
                self._serve(robot, now)
            else:
                state.phase, state.since = HOLDING, now

    # ------------------------------------------------------------------ a live fleet

    def add_task(self, predecessors: Sequence[int], service_time: float, now: float, outcome: EventOutcome,
                 known: bool = True) -> int:
        """A task added during the episode (its predecessors among the existing tasks): its index."""
        task = len(self.service)
        self.predecessors.append(tuple(predecessors))
        self.successors.append([])
        for p in predecessors:
            self.successors[p].append(task)
        self.service.append(float(service_time))
        self.known.append(bool(known))
        self.cancelled.append(False)
        self.finished.append(False)
        self.finish_time.append(None)
        self.finished_by.append(None)
        self._release([task], now, outcome)
        self.fleet_changed()
        return task

    def release(self, task: int, now: float, outcome: EventOutcome) -> None:
        """A task becomes known (its release time came)."""
        self.known[task] = True
        self._release([task], now, outcome)
        self.fleet_changed()

    def cancel(self, task: int, now: float, outcome: EventOutcome) -> List[int]:
        """The task is dropped before it starts; the robots freed from it (driving there: their legs
        must be stopped; holding there). ValueError (one phrase) when it is finished, already
        cancelled, or in service."""
        if self.finished[task]:
            raise ValueError("already finished")
        if self.cancelled[task]:
            raise ValueError("already cancelled")
        serving = [i for i, r in enumerate(self.robots) if r.task == task and r.phase == SERVING]
        if serving:
            raise ValueError(f"in service since {self.robots[serving[0]].since:.2f} s: a started task is not cancelled")
        self.cancelled[task] = True
        freed = []
        for robot, state in enumerate(self.robots):
            if state.task == task and state.phase in (DRIVING, HOLDING):
                attempt = self.attempts[robot]
                attempt.failure = "cancelled"
                if state.phase == DRIVING:
                    attempt.nav_time = now - state.leg_start
                else:
                    attempt.held = now - state.since
                outcome.ended.append(self._free(robot, now))
                freed.append(robot)
        # Its successors wait for its own predecessors instead: the order among the rest is kept.
        bridged = self.predecessors[task]
        successors = self.successors[task]
        for successor in successors:
            preds = [p for p in self.predecessors[successor] if p != task]
            preds += [p for p in bridged if p not in preds]
            self.predecessors[successor] = tuple(preds)
            for p in bridged:
                if successor not in self.successors[p]:
                    self.successors[p].append(successor)
        for p in bridged:
            self.successors[p].remove(task)
        self.successors[task] = []
        self._release(successors, now, outcome)
        self.fleet_changed()
        return freed

    def remove_robot(self, robot: int, now: float, reason: str, outcome: EventOutcome) -> bool:
        """The robot leaves the fleet; its task (driven to, held or served) returns to the pool
        unfinished. Returns whether it was driving (its leg must be stopped). ValueError when it
        has left already."""
        state = self.robots[robot]
        if state.phase == LEFT:
            raise ValueError("has left already")
        driving = state.phase == DRIVING
        attempt = self.attempts[robot]
        task = state.task
        if attempt is not None:
            attempt.failure = reason
            if driving:
                attempt.nav_time = now - state.leg_start
            elif state.phase == HOLDING:
                attempt.held = now - state.since
            outcome.ended.append(attempt)
        self.attempts[robot] = None
        state.phase, state.task, state.since = LEFT, None, now
        self.due.discard(robot)
        if task is not None:
            self._release([task], now, outcome)
        self.fleet_changed()
        return driving

    def add_robot(self, robot: int, now: float) -> None:
        """A robot that had left joins again: idle, and due. ValueError when it is in the fleet."""
        state = self.robots[robot]
        if state.phase != LEFT:
            raise ValueError("is in the fleet already")
        state.phase, state.task, state.since, state.decided_at = IDLE, None, now, now
        self.fleet_changed()

    def fleet_changed(self) -> None:
        """The idle and the holding robots decide (see the module docstring)."""
        self.due.update(i for i, r in enumerate(self.robots) if r.phase in (IDLE, HOLDING))

    # ------------------------------------------------------------------ helpers

    def _serve(self, robot: int, start: float) -> None:
        state = self.robots[robot]
        attempt = self.attempts[robot]
        attempt.service_start = start
        attempt.held = start - attempt.arrived_at
        state.phase, state.since, state.service_end = SERVING, start, start + self.service[state.task]

    def _finish(self, robot: int, time: float, outcome: EventOutcome) -> None:
        state = self.robots[robot]
        task = state.task
        self.finished[task], self.finish_time[task], self.finished_by[task] = True, time, robot
        attempt = self.attempts[robot]
        attempt.finish_time = time
        outcome.finished.append((task, robot, time))
        outcome.ended.append(attempt)
        self.attempts[robot] = None
        state.phase, state.task, state.since = IDLE, None, time
        self.due.add(robot)
        self._release(self.successors[task], time, outcome)

    def _release(self, tasks: Sequence[int], time: float, outcome: EventOutcome) -> None:
        """Of `tasks`, those now ready start their service where a robot holds at them (the first
        to arrive serves; others are freed) or else make the idle robots due."""
        for successor in tasks:
            if self.ready(successor):
                outcome.released.append(successor)
                held = [i for i, r in enumerate(self.robots) if r.phase == HOLDING and r.task == successor]
                if held:
                    self._serve(held[0], time)   # the first to arrive serves; others stay until freed
                    for other in held[1:]:
                        self.attempts[other].wasted = True
                        ended = self._free(other, time)
                        if ended is not None:
                            outcome.ended.append(ended)
                else:
                    self.due.update(i for i, r in enumerate(self.robots) if r.phase == IDLE)

    def _free(self, robot: int, now: float) -> Attempt:
        state = self.robots[robot]
        attempt = self.attempts[robot]
        self.attempts[robot] = None
        state.phase, state.task, state.since = IDLE, None, now
        self.due.add(robot)
        return attempt

    def snapshot(self) -> Dict[str, object]:
        """The state in plain values (tests, logs)."""
        return {"phases": [r.phase for r in self.robots], "tasks": [r.task for r in self.robots],
                "finished": list(self.finished), "due": sorted(self.due), "known": list(self.known),
                "cancelled": list(self.cancelled)}


def route_actions(routes: Sequence[Sequence[int]], finished: Sequence[bool], deciding: Sequence[bool],
                  none: int) -> List[int]:
    """Routes carried out as events: each deciding robot takes the first task of its route that is
    not finished (a leg that failed is driven again), or None (`none`) when its route is done; the
    other robots' actions are None (ignored). The one rule of a plan's event dispatch."""
    actions = [none] * len(deciding)
    for robot, free in enumerate(deciding):
        if free and robot < len(routes):
            actions[robot] = next((task for task in routes[robot] if not finished[task]), none)
    return actions
