"""The schedule of a live fleet as it stands: what the task manager publishes on `~fleet_status` and
draws in rviz, ROS-free (ros/fleet_services.py turns it into marl_mrta/FleetStatus).

Read from an event-mode environment (env/event_env.py: its rules, record and scenario) between two
of its instants, in the thread that runs its episode, so that it is never seen half changed.
- A task is listed once it is known (released, submitted or from the start): `cancelled`,
  `finished`, else `serving`, `holding` or `driving` when a robot does that with it, else `ready`
  (every predecessor finished) or `open`. Its predecessors are those it waits for now: a cancelled
  task's successors wait for its own predecessors instead (model/event_rules.py).
- A robot is `idle`, `driving`, `holding`, `serving` or `left`, with its task.
- `submitted`: the task came by ~submit_tasks (the record's fleet events). `orphaned`: its robot
  left the fleet while it was that robot's task, and no robot has taken it since (FleetMarks
  follows the robots from instant to instant to tell).
Times are s since the episode's start; NOT_YET where there is none yet.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Set, Tuple

from marl_mrta.model.event_rules import DRIVING, HOLDING, LEFT, SERVING

#: Task statuses, in the order a task goes through them (cancelled instead of the rest).
OPEN, READY, FINISHED, CANCELLED = "open", "ready", "finished", "cancelled"
TASK_STATUSES = (OPEN, READY, DRIVING, HOLDING, SERVING, FINISHED, CANCELLED)
#: The time of something that has not happened (a start, a finish).
NOT_YET = -1.0
#: Of several robots with one task (a wasted trip under way), the one shown: who stands there first.
_SHOWN_FIRST = {SERVING: 0, HOLDING: 1, DRIVING: 2}


@dataclass(frozen=True)
class TaskStatus:
    id: str
    category: str
    status: str                       # TASK_STATUSES
    robot: str                        # "" none
    predecessors: Tuple[str, ...]
    submitted: bool
    orphaned: bool
    released_at: float                # s
    start: float                      # s: service start, or NOT_YET
    finish: float                     # s, or NOT_YET
    x: float                          # m, its goal in the map frame
    y: float


@dataclass(frozen=True)
class RobotStatus:
    id: str
    status: str                       # idle | driving | holding | serving | left
    task: str                         # "" none
    x: float                          # m
    y: float
    left_reason: str = ""             # status left: the record's account of it


@dataclass(frozen=True)
class FleetSnapshot:
    running: bool                     # an episode runs
    elapsed: float                    # s since the episode's start
    tasks: Tuple[TaskStatus, ...]
    robots: Tuple[RobotStatus, ...]

    def task(self, task_id: str) -> Optional[TaskStatus]:
        return next((t for t in self.tasks if t.id == task_id), None)

    def robot(self, robot_id: str) -> Optional[RobotStatus]:
        return next((r for r in self.robots if r.id == robot_id), None)


class FleetMarks:
    """What a snapshot cannot read from the rules alone: the tasks orphaned by a robot that left.
    `follow(rules)` after every change (each instant, each request); `reset()` at an episode's start."""

    def __init__(self):
        self.reset()

    def reset(self) -> None:
        self._tasks: List[Optional[int]] = []     # per robot, its task at the last follow()
        self.orphaned: Set[int] = set()

    def follow(self, rules) -> None:
        robots = rules.robots
        for robot, state in enumerate(robots):
            before = self._tasks[robot] if robot < len(self._tasks) else None
            if state.phase == LEFT and before is not None:
                self.orphaned.add(before)
        taken = {state.task for state in robots if state.task is not None and state.phase != LEFT}
        self.orphaned = {task for task in self.orphaned if rules.open(task) and task not in taken}
        self._tasks = [state.task if state.phase != LEFT else None for state in robots]


def _service_starts(record, rules) -> Dict[int, float]:
    """Per task, when its service started: the finishing entry's, or the serving robot's attempt's."""
    starts = {entry.task: entry.service_start for entry in record.entries
              if entry.finished and entry.service_start is not None}
    for robot, state in enumerate(rules.robots):
        attempt = rules.attempts[robot]
        if state.phase == SERVING and attempt is not None and attempt.service_start is not None:
            starts[state.task] = attempt.service_start
    return starts


def fleet_snapshot(env, poses: Sequence[Tuple[float, float, float]], running: bool, marks: FleetMarks,
                   elapsed: Optional[float] = None) -> FleetSnapshot:
    """The fleet of an event-mode environment as it stands; `poses` the robots' (x, y, yaw),
    `elapsed` the time of the instant (default: the environment's last decision instant)."""
    rules, record, scenario = env.rules, env.record, env.scenario
    robot_ids = [robot.id for robot in scenario.robots]
    submitted = {event["subject"] for event in record.fleet_events if event["event"] == "submitted"}
    left_reasons = {event["subject"]: event["detail"] for event in record.fleet_events if event["event"] == "left"}
    starts = _service_starts(record, rules)
    holder: Dict[int, Tuple[int, int]] = {}   # task -> (rank, robot)
    for robot, state in enumerate(rules.robots):
        if state.task is not None and state.phase in _SHOWN_FIRST:
            rank = (_SHOWN_FIRST[state.phase], robot)
            holder[state.task] = min(holder.get(state.task, rank), rank)
    tasks: List[TaskStatus] = []
    for j, spec in enumerate(scenario.tasks[:rules.n_tasks]):
        released = record.released_at[j] if j < len(record.released_at) else None
        if not rules.known[j] or released is None:
            continue   # not released yet: no one is to know of it
        robot = ""
        if rules.cancelled[j]:
            status = CANCELLED
        elif rules.finished[j]:
            status = FINISHED
            robot = robot_ids[rules.finished_by[j]] if rules.finished_by[j] is not None else ""
        elif j in holder:
            status = rules.robots[holder[j][1]].phase
            robot = robot_ids[holder[j][1]]
        else:
            status = READY if rules.ready(j) else OPEN
        finish = rules.finish_time[j]
        tasks.append(TaskStatus(spec.id, spec.category, status, robot,
                                tuple(scenario.tasks[p].id for p in rules.predecessors[j]), spec.id in submitted,
                                j in marks.orphaned, float(released), starts.get(j, NOT_YET),
                                NOT_YET if finish is None else float(finish), spec.goal.x, spec.goal.y))
    robots = []
    for robot, state in enumerate(rules.robots):
        x, y = poses[robot][0], poses[robot][1]
        task = scenario.tasks[state.task].id if state.task is not None else ""
        reason = left_reasons.get(robot_ids[robot], "") if state.phase == LEFT else ""
        robots.append(RobotStatus(robot_ids[robot], state.phase, task, float(x), float(y), reason))
    return FleetSnapshot(running, float(env.elapsed if elapsed is None else elapsed), tuple(tasks), tuple(robots))


def same_schedule(a: Optional[FleetSnapshot], b: Optional[FleetSnapshot]) -> bool:
    """Whether two snapshots show the same schedule (the robots' poses and the time aside): a new
    one is published only when this changes."""
    if a is None or b is None:
        return a is b
    strip = [(r.id, r.status, r.task, r.left_reason) for r in a.robots], [(r.id, r.status, r.task, r.left_reason)
                                                                          for r in b.robots]
    return a.running == b.running and a.tasks == b.tasks and strip[0] == strip[1]


def describe(snapshot: FleetSnapshot) -> List[str]:
    """The snapshot as lines of text (`fleet status`)."""
    def when(t: float) -> str:
        return "-" if t == NOT_YET else f"{t:.1f}"

    lines = [f"{'running' if snapshot.running else 'no episode running'}, {snapshot.elapsed:.1f} s",
             f"{'task':<10} {'status':<10} {'robot':<8} {'released':>8} {'start':>7} {'finish':>7}  after"]
    for t in snapshot.tasks:
        marks = "".join([" (new)" if t.submitted else "", " (orphaned)" if t.orphaned else ""])
        lines.append(f"{t.id:<10} {t.status:<10} {t.robot or '-':<8} {when(t.released_at):>8} {when(t.start):>7} "
                     f"{when(t.finish):>7}  {', '.join(t.predecessors) or '-'}{marks}")
    lines.append(f"{'robot':<10} {'status':<10} {'task':<8} {'x':>6} {'y':>6}")
    for r in snapshot.robots:
        why = f"  ({r.left_reason})" if r.left_reason else ""
        lines.append(f"{r.id:<10} {r.status:<10} {r.task or '-':<8} {r.x:>6.2f} {r.y:>6.2f}{why}")
    return lines
