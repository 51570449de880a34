"""Re-planning a live fleet in event mode: routes for the robots from the fleet as it stands.

At every change of the fleet (a task released or submitted, a task cancelled, a robot that leaves
or joins: env/live_fleet.py), and when the robots run late against the plan, the replanning
allocator (evaluation/policies.py's ReplanPolicy) plans again for the robots still in the fleet
and the tasks still open (fleet_instance):
- each robot from where it comes free: an idle robot from its node, now; a robot holding at a
  task that decides now from there, now (staying costs nothing, leaving is allowed); a robot
  driving to, serving, or holding at a task without a decision now keeps that task first on
  its route (a leg or a service is not broken off), from its leg's start, its service start or
  its arrival;
- the open tasks known now, with their unfinished predecessors (a task whose predecessor is not
  known yet waits for a later plan);
- legs from the nominal travel table, direct (event mode), in the episode's absolute time.

The plan (repair): the previous plan's routes with closed tasks dropped and the others inserted
where they lengthen the plan least (cheapest insertion), then the GA and CP-SAT's asynchronous
model from the best so far, within config/task_baselines.yaml's `replan` budget; the shortest
plan wins (then the least sum of finish times). The same planner told everything at the start
(full_information_instance: every release, and when each robot will leave) is the live fleet's
yardstick (apps/bench_fleet.py).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from marl_mrta.baselines.cpsat import CpSatBudget
from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.plan import EventRun, Plan, SchedulingInstance, decode_routes, plan_from_run
from marl_mrta.baselines.relaxation import solve_relaxation
from marl_mrta.baselines.settings import GaSettings, ReplanSettings
from marl_mrta.model.event_rules import DRIVING, HOLDING, SERVING

METHODS = ("insertion", "ga", "cpsat")
#: The GA of a re-plan: the paper's settings with a smaller population (its budget is evaluations).
_GA = GaSettings(population=30, stall_generations=20)


@dataclass
class FleetView:
    """A live fleet as a SchedulingInstance, and the way back to the episode's indices."""

    instance: SchedulingInstance
    robots: List[int]              # instance robot k -> episode robot
    tasks: List[int]               # instance task k -> episode task

    def to_episode(self, routes: Sequence[Sequence[int]], n_robots: int) -> List[List[int]]:
        """Routes of the instance as per-robot routes of the episode (robots not planned: empty)."""
        episode: List[List[int]] = [[] for _ in range(n_robots)]
        for k, route in enumerate(routes):
            episode[self.robots[k]] = [self.tasks[t] for t in route]
        return episode


def plannable_tasks(rules) -> List[int]:
    """Open tasks whose unfinished predecessors are all plannable (known and open), in index order."""
    plannable: set = set()
    changed = True
    while changed:
        changed = False
        for j in range(rules.n_tasks):
            if j not in plannable and rules.open(j) and \
                    all(rules.finished[p] or p in plannable for p in rules.predecessors[j]):
                plannable.add(j)
                changed = True
    return sorted(plannable)


def fleet_instance(env) -> FleetView:
    """The fleet of an event-mode episode (env/event_env.py) as it stands now; see the module docstring."""
    rules, table, now = env.rules, env.table, env.elapsed
    tasks = plannable_tasks(rules)
    task_index = {j: k for k, j in enumerate(tasks)}
    nodes = env.robot_nodes()
    robots, robot_nodes, ready, first = [], [], [], []
    for r, state in enumerate(rules.robots):
        if not rules.present(r):
            continue
        # A holding robot that does not decide now keeps its task (nothing tells it otherwise).
        if state.phase in (DRIVING, SERVING) or (state.phase == HOLDING and r not in rules.due):
            if state.task not in task_index:
                continue   # committed to a task that waits for one not known yet: planned later
            task_node = env.n_agents + state.task
            if state.phase == DRIVING:
                start = env.leg_start_node(r)
                start = nodes[r] if start is None else start
                leg = float(table.nominal_time[start, task_node])
                robot_nodes.append(start)
                ready.append(max(state.leg_start, now - leg))   # a leg running late arrives no earlier than now
            else:
                robot_nodes.append(task_node)
                ready.append(state.since)   # its service start, or its arrival (holding)
            first.append(task_index[state.task])
        else:   # idle, or holding and deciding: free now (a holding robot may stay, at no cost, or leave)
            robot_nodes.append(env.n_agents + state.task if state.phase == HOLDING else nodes[r])
            ready.append(now)
            first.append(None)
        robots.append(r)
    rows = robot_nodes + [env.n_agents + j for j in tasks]
    travel = np.array(table.nominal_time, dtype=float)[np.ix_(rows, rows)]
    for k, r in enumerate(robots):
        state = rules.robots[r]
        if state.phase in (HOLDING, SERVING) and state.task in task_index:
            travel[k, len(robots) + task_index[state.task]] = 0.0   # it stands there already
    rule = env.settings.goal_timeout
    instance = SchedulingInstance(
        len(robots), len(tasks), travel, tuple(rules.service[j] for j in tasks),
        tuple(tuple(task_index[p] for p in rules.predecessors[j] if not rules.finished[p]) for j in tasks),
        env.settings.min_step, tuple(env.scenario.tasks[j].id for j in tasks), rule.planning_limit,
        decision_mode="event", robot_ready=tuple(ready), first_task=tuple(first))
    return FleetView(instance, robots, tasks)


def full_information_instance(scenario, table, goal_timeout: float, min_step: float) -> SchedulingInstance:
    """The live scenario told everything at the start: every task with its release, and each
    robot's departure (<faults>) as the time by which its tasks must be finished."""
    deadline = [math.inf] * scenario.n_robots
    for fault in scenario.faults:
        deadline[fault.robot] = fault.at
    return SchedulingInstance(scenario.n_robots, scenario.n_tasks, np.array(table.nominal_time),
                              tuple(t.service_time for t in scenario.tasks), tuple(scenario.predecessors), min_step,
                              tuple(t.id for t in scenario.tasks), goal_timeout, decision_mode="event",
                              task_release=tuple(t.release for t in scenario.tasks),
                              robot_deadline=tuple(deadline))


def _score(run: EventRun) -> Tuple[float, float]:
    """Shorter makespan first, then the smaller sum of finish times."""
    if not run.complete:
        return math.inf, math.inf
    return run.elapsed, sum(f for f in run.finish if f is not None)


def insertion_routes(instance: SchedulingInstance, routes: Sequence[Sequence[int]]) -> List[List[int]]:
    """`routes` (instance indices; others dropped) with every task not on them inserted, in
    precedence order, where it lengthens the plan least (cheapest insertion)."""
    routes = [list(route) for route in routes] + [[] for _ in range(instance.n_robots - len(routes))]
    placed = {t for route in routes for t in route}
    committed = {instance.committed(r): r for r in range(instance.n_robots) if instance.committed(r) is not None}
    for task, robot in committed.items():
        if task not in placed:
            routes[robot].insert(0, task)
            placed.add(task)
    pending = [t for t in range(instance.n_tasks) if t not in placed]
    while pending:
        # a task whose predecessors are placed (precedence order: the routes stay decodable)
        task = next((t for t in pending if all(p in placed for p in instance.predecessors[t])), pending[0])
        pending.remove(task)
        best: Optional[Tuple[Tuple[float, float], int, int]] = None
        for robot in range(instance.n_robots):
            begin = 1 if instance.committed(robot) is not None else 0
            for position in range(begin, len(routes[robot]) + 1):
                trial = [list(route) for route in routes]
                trial[robot].insert(position, task)
                score = _score(decode_routes(instance, trial))
                if best is None or score < best[0]:
                    best = (score, robot, position)
        if best is None:   # no robot in the fleet
            continue
        routes[best[1]].insert(best[2], task)
        placed.add(task)
    return routes


def repair(instance: SchedulingInstance, previous: Sequence[Sequence[int]], settings: ReplanSettings) -> Plan:
    """The best plan of the instance from `previous` routes (instance indices); see the module docstring."""
    if instance.n_robots == 0:
        return Plan("replan", [], [], math.inf, 0, instance=instance)
    candidates: List[Tuple[List[List[int]], str]] = [(insertion_routes(instance, previous), "insertion")]
    if settings.method in ("ga", "cpsat") and instance.n_tasks > 1:
        ga = solve_ga(instance, dataclasses.replace(_GA, max_evaluations=settings.ga_evaluations), settings.seed)
        candidates.append((ga.robot_tasks, "ga"))
    best_routes, best_source = min(candidates, key=lambda c: _score(decode_routes(instance, c[0])))
    if settings.method == "cpsat" and instance.n_tasks > 1:
        hint = plan_from_run("replan", decode_routes(instance, best_routes))
        upper = hint.makespan if math.isfinite(hint.makespan) else None
        budget = CpSatBudget(time_limit=settings.time_limit, seed=settings.seed)
        relaxed = solve_relaxation(instance, budget, "asynchronous", hint if hint.usable else None, upper,
                                   direct_legs=True)
        bound = relaxed.lower_bound
        if relaxed.routes is not None:
            candidates.append((relaxed.routes, "cpsat"))
            best_routes, best_source = min(candidates, key=lambda c: _score(decode_routes(instance, c[0])))
        best_run = decode_routes(instance, best_routes)
        if best_run.complete:
            # The shortest plan's makespan kept, the least sum of finish times within it.
            hint = plan_from_run("replan", best_run)
            least = solve_relaxation(instance, budget, "asynchronous", hint, hint.makespan, makespan_cap=hint.makespan,
                                     direct_legs=True, least_finishes=True)
            if least.routes is not None:
                candidates.append((least.routes, "cpsat"))
                best_routes, best_source = min(candidates, key=lambda c: _score(decode_routes(instance, c[0])))
        return plan_from_run("replan", decode_routes(instance, best_routes), source=best_source, lower_bound=bound,
                             cpsat=relaxed.status)
    return plan_from_run("replan", decode_routes(instance, best_routes), source=best_source)


def planned_finishes(view: FleetView, plan: Plan) -> Dict[int, float]:
    """Per episode task of the plan, its planned finish (s, absolute)."""
    run = decode_routes(view.instance, plan.robot_tasks)
    return {view.tasks[k]: f for k, f in enumerate(run.finish) if f is not None}
