"""Plans in event mode: per-robot routes carried out as event dispatch.

Each robot takes the next task of its route the moment it comes free (model/event_rules.py): it
drives there over the direct leg, waits there for the task's predecessors if they are not all
finished, and serves it. With nominal legs that is the earliest-start schedule of the routes:

    arrival(j) = finish(previous task of j's route) + leg(previous node, node of j)   (0 + leg from
                 the robot's start for its first task)
    start(j)   = max(arrival(j), finish of every predecessor of j)
    finish(j)  = start(j) + service(j);   makespan = the last finish.

Routes that wait on each other in a cycle (a robot holds at a task whose predecessor comes later
on a route that waits in turn) never finish: such a plan is incomplete (makespan inf), as is one
with a leg beyond the goal timeout (the environment fails it). test_event_mode.py checks this
schedule against the environment's own episodes of the same routes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Optional, Sequence

from marl_mrta.baselines.plan import SchedulingInstance


@dataclass
class EventRun:
    """What the planners read of a decoded plan (the fields of plan.NominalRun they use)."""

    instance: SchedulingInstance
    robot_tasks: List[List[int]]
    elapsed: float                       # s, the makespan (inf when incomplete)
    complete: bool
    arrival: List[Optional[float]] = field(default_factory=list)   # per task
    start: List[Optional[float]] = field(default_factory=list)     # per task: its service start
    finish: List[Optional[float]] = field(default_factory=list)    # per task
    joint_actions: List[List[Optional[int]]] = field(default_factory=list)   # none: no steps in event mode
    violations: int = 0                  # never out of order: robots wait for predecessors


def decode_routes(instance: SchedulingInstance, routes: Sequence[Sequence[int]]) -> EventRun:
    """The earliest-start schedule of `routes` (each task in at most one route)."""
    n_t = instance.n_tasks
    rows = instance.travel_rows
    route_of: List[Optional[int]] = [None] * n_t
    before: List[Optional[int]] = [None] * n_t      # the previous task on its route
    for robot, route in enumerate(routes):
        for k, task in enumerate(route):
            route_of[task] = robot
            before[task] = route[k - 1] if k else None
    arrival: List[Optional[float]] = [None] * n_t
    start: List[Optional[float]] = [None] * n_t
    finish: List[Optional[float]] = [None] * n_t
    lists = [list(route) for route in routes]
    pending = [t for route in lists for t in route]
    while pending:
        progressed = False
        rest = []
        for task in pending:
            prev = before[task]
            if (prev is not None and finish[prev] is None) or any(finish[p] is None for p in instance.predecessors[task]):
                rest.append(task)
                continue
            robot = route_of[task]
            node = instance.node(prev) if prev is not None else robot
            leg = rows[node][instance.node(task)]
            if leg > instance.goal_timeout:
                return EventRun(instance, lists, math.inf, False, arrival, start, finish)
            arrival[task] = (finish[prev] if prev is not None else 0.0) + leg
            start[task] = max([arrival[task]] + [finish[p] for p in instance.predecessors[task]])
            finish[task] = start[task] + instance.service[task]
            progressed = True
        if not progressed:   # routes that wait on each other: a deadlock
            return EventRun(instance, lists, math.inf, False, arrival, start, finish)
        pending = rest
    complete = all(f is not None for f in finish)
    makespan = max(finish) if complete and finish else (0.0 if n_t == 0 else math.inf)
    return EventRun(instance, lists, makespan, complete, arrival, start, finish)
