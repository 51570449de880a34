"""The task rules of one decision step (Algorithm 1), shared by the environment and the planners.

Given what each robot was told to do and what its navigation did (arrival or not, after how
long), decide who finished which task, whether each attempt respected the precedence, how long
the step lasted and how long each robot waited. Times are relative to the start of the step.

Rules (docs/guide/evaluation.md):
- A task is finished by the first robot to arrive at its goal (ties: lower robot index), if it
  was not finished before and its service time ends within the episode's time limit. Another
  robot arriving there later finishes nothing (wasted trip, never a double finish).
- An attempt is in correct order if every predecessor of the task was finished strictly before
  the robot arrived (or, for an attempt that did not arrive, before the attempt ended).
  Planners may ask for more: `order_margin` seconds between the predecessor's finish and the
  arrival, so that their plans stay in order when real legs run late (the environment asks 0).
- With `hold_successors` (config/task.yaml; real.launch's default), a robot that arrives at a
  task before a predecessor is finished waits there and serves it from the predecessor's finish:
  a floor with real precedence never has a task done out of order. If a predecessor is not
  finished in the step, the robot serves nothing and the task stays open (in correct order).
- The step lasts until the last robot with a goal has arrived (plus its service time) or
  failed, and at least `min_step` seconds (the whole step when every robot chose None, or
  when a robot was sent to where it already stands). Never beyond the time limit.
- Idle time of a robot = step duration − its busy time (navigation + service); a robot with
  action None is idle for the whole step.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

from marl_mrta.common.records import STEP_RECORD


@dataclass(**STEP_RECORD)
class FinishedTask:
    task: int
    robot: int
    reach_time: float        # arrival, relative to the step start
    finish_time: float       # arrival + service time, relative to the step start


@dataclass(**STEP_RECORD)
class StepResolution:
    """The outcome of one step. Per-robot lists are indexed by robot."""

    tasks: List[Optional[int]]       # task index, None for the None action
    reached: List[bool]              # arrived at the task's goal within the step
    robot_finished: List[bool]       # this robot finished its task
    correct_order: List[bool]        # predecessors finished strictly before arrival (True for None)
    nav_time: List[float]            # s navigated (to arrival, failure or time limit)
    busy_time: List[float]           # nav_time + service time if this robot finished the task
    idle_time: List[float]           # duration − busy_time
    collisions: List[int]            # collision events of each robot in the step
    duration: float                  # s
    finished: List[FinishedTask]     # tasks finished in this step, in order of their finish time
    held: List[float]                # s each robot waited at its task for predecessors (hold_successors)


def _finish_order(task: FinishedTask) -> Tuple[float, int]:
    return task.finish_time, task.robot


def resolve_step(goals: Sequence[Optional[int]], nav_times: Sequence[float], reached: Sequence[bool],
                 collisions: Sequence[int], finished_before: Sequence[bool],
                 predecessors: Sequence[Sequence[int]], service_times: Sequence[float],
                 time_limit: float, min_step: float, order_margin: float = 0.0,
                 hold_successors: bool = False) -> StepResolution:
    """Apply the step rules to one joint action and its navigation outcome."""
    n_robots = len(goals)
    # First arrival at each task that is still open.
    first_robot = {}
    for robot, task in enumerate(goals):
        if task is None or not reached[robot] or finished_before[task]:
            continue
        best = first_robot.get(task)
        if best is None or nav_times[robot] < nav_times[best]:
            first_robot[task] = robot
    # Service starts: the arrival, or with hold_successors the predecessors' finish (absent: not served).
    held_starts = (_held_starts({task: nav_times[robot] for task, robot in first_robot.items()}, finished_before,
                                predecessors, service_times) if hold_successors else None)
    finish_rel = {}
    finished: List[FinishedTask] = []
    for task, robot in first_robot.items():
        start = nav_times[robot] if held_starts is None else held_starts.get(task)
        if start is None:
            continue
        end = start + service_times[task]
        if end <= time_limit:
            finish_rel[task] = end
            finished.append(FinishedTask(task, robot, nav_times[robot], end))
    if len(finished) > 1:
        finished.sort(key=_finish_order)

    robot_finished = [False] * n_robots
    correct_order = [True] * n_robots
    nav = [0.0] * n_robots
    busy = [0.0] * n_robots
    held = [0.0] * n_robots
    duration = 0.0
    for robot, task in enumerate(goals):
        if task is None:
            continue
        t = nav[robot] = nav_times[robot]
        if hold_successors and first_robot.get(task) == robot:
            # In order by construction: served from its predecessors' finish, or not at all.
            if task in finish_rel:
                held[robot] = finish_rel[task] - service_times[task] - t
                t += held[robot]
        else:
            for pred in predecessors[task]:
                if finished_before[pred]:
                    continue
                done_at = finish_rel.get(pred)
                if done_at is None or not done_at + order_margin < t:
                    correct_order[robot] = False
                    break
        if task in finish_rel and first_robot[task] == robot:
            robot_finished[robot] = True
            t += service_times[task]
        busy[robot] = t
        if t > duration:
            duration = t
    duration = min(max(duration, min_step), time_limit)
    idle = [duration - b if duration > b else 0.0 for b in busy]
    return StepResolution(list(goals), [bool(r) and g is not None for r, g in zip(reached, goals)], robot_finished,
                          correct_order, nav, busy, idle, list(collisions), duration, finished, held)


def _held_starts(arrivals: Dict[int, float], finished_before: Sequence[bool],
                 predecessors: Sequence[Sequence[int]], service_times: Sequence[float]) -> Dict[int, float]:
    """Service starts under hold_successors: at arrival, or at the last predecessor's finish when
    it finishes later in the step (chains within a step resolve in precedence order). Tasks with
    a predecessor that does not finish in the step are left out: they are not served."""
    starts: Dict[int, float] = {}
    pending = dict(arrivals)
    while pending:
        progressed = False
        for task, arrival in list(pending.items()):
            open_preds = [p for p in predecessors[task] if not finished_before[p]]
            if any(p not in starts and p in pending for p in open_preds):
                continue   # a predecessor's own start is not known yet
            del pending[task]
            progressed = True
            if any(p not in starts for p in open_preds):
                continue   # a predecessor not reached in this step
            starts[task] = max([arrival] + [starts[p] + service_times[p] for p in open_preds])
        if not progressed:
            break
    return starts
