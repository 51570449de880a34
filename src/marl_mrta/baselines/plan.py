"""What planners work on and what they produce.

SchedulingInstance: a scenario reduced to nominal numbers (travel times between nodes, service
times, precedence, the goal timeout). Plan: per-robot ordered task lists plus the per-step joint
actions that carry them out under the environment's step rules (model/rules.py), so a plan can
be replayed through the environment and scored by the same rules as every other method. In event
mode a plan is its routes alone, carried out as events (decode_routes, at the end).
"""
from __future__ import annotations

import dataclasses
import heapq
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from marl_mrta.model.rules import StepResolution, resolve_step

INFINITE_TIME = math.inf


@dataclass(frozen=True)
class SchedulingInstance:
    """Nodes 0..n_robots−1 are the robots' start poses, node n_robots + j is task j's goal.

    goal_timeout: a leg that takes longer fails in the environment (the robot stays where it
    was), so planners only use legs within it and reach farther goals over other goals; inf with
    an auto goal timeout (model/goal_timeout.py), under which no nominal leg fails.
    precedence_margin: in plans, a task finished in the same step as a predecessor is reached
    at least this long after the predecessor's finish (the rules ask only "after"), so that the
    plan stays in order when real legs run late against each other (config/task_baselines.yaml).
    hold_successors: plans for the step rules' hold (model/rules.py), where the task manager runs
    it: a robot may be sent to a task whose predecessors finish later in the step (it waits
    there and serves it after them) or in a later step (it stands there unserved until then),
    and the margin is not needed. Every plan of the paper's rules keeps its makespan under it.
    decision_mode: synchronous (the step rules) or event (robots take the next task of their route
    when they come free and wait at a task for its predecessors: baselines/plan.py).

    A live fleet (event mode only, baselines/replan.py) plans from the fleet as it stands, in the
    episode's absolute time: robot_ready, when each robot is free on its node (empty: all at 0);
    task_release, the earliest service start of each task (empty: 0); robot_deadline, by when
    each robot's tasks must be finished (a robot known to leave then; empty: never); first_task,
    the task a robot is already committed to (driving to, holding at or serving), its route's
    first (empty or None: none).
    """

    n_robots: int
    n_tasks: int
    travel: np.ndarray                          # (n_nodes, n_nodes) s, nominal leg times
    service: Tuple[float, ...]                  # per task, s
    predecessors: Tuple[Tuple[int, ...], ...]   # per task
    min_step: float = 1.0
    task_ids: Tuple[str, ...] = ()
    goal_timeout: float = INFINITE_TIME
    precedence_margin: float = 0.0              # s
    hold_successors: bool = False
    decision_mode: str = "synchronous"
    robot_ready: Tuple[float, ...] = ()
    task_release: Tuple[float, ...] = ()
    robot_deadline: Tuple[float, ...] = ()
    first_task: Tuple[Optional[int], ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "travel_rows", np.asarray(self.travel, dtype=float).tolist())
        if not self.task_ids:
            object.__setattr__(self, "task_ids", tuple(f"T{j}" for j in range(self.n_tasks)))
        if self.live and self.decision_mode != "event":
            raise ValueError("ready times, releases, deadlines and committed tasks are of event mode's plans")

    @property
    def live(self) -> bool:
        """The instance carries a live fleet's state (ready times, releases, deadlines, commitments)."""
        return bool(self.robot_ready or self.task_release or self.robot_deadline
                    or any(t is not None for t in self.first_task))

    def ready_time(self, robot: int) -> float:
        return self.robot_ready[robot] if self.robot_ready else 0.0

    def release(self, task: int) -> float:
        return self.task_release[task] if self.task_release else 0.0

    def deadline(self, robot: int) -> float:
        return self.robot_deadline[robot] if self.robot_deadline else math.inf

    def committed(self, robot: int) -> Optional[int]:
        return self.first_task[robot] if self.first_task else None

    def node(self, task: int) -> int:
        return self.n_robots + task

    def leg_feasible(self, a: int, b: int) -> bool:
        """A leg from node a to node b arrives within the goal timeout."""
        return self.travel_rows[a][b] <= self.goal_timeout

    def chain_times(self) -> np.ndarray:
        """Shortest chains of feasible legs between nodes (Floyd–Warshall; inf: no chain; 0 on the
        diagonal): what a robot needs at least to get from one node to another over any goals."""
        cached = self.__dict__.get("_chain_times")
        if cached is None:
            closure = np.asarray(self.travel, dtype=float).copy()
            closure[closure > self.goal_timeout] = np.inf
            np.fill_diagonal(closure, 0.0)
            for k in range(closure.shape[0]):
                closure = np.minimum(closure, closure[:, k:k + 1] + closure[k:k + 1, :])
            closure.setflags(write=False)
            object.__setattr__(self, "_chain_times", closure)
            cached = closure
        return cached

    def unreachable_tasks(self) -> List[int]:
        """Tasks no robot can reach from its start by any chain of feasible legs."""
        chains = self.chain_times()[:self.n_robots, self.n_robots:]
        return [j for j in range(self.n_tasks) if not np.isfinite(chains[:, j]).any()]

    @staticmethod
    def from_scenario(scenario, table, min_step: float, goal_timeout: float = INFINITE_TIME,
                      precedence_margin: float = 0.0, hold_successors: bool = False,
                      decision_mode: str = "synchronous") -> "SchedulingInstance":
        return SchedulingInstance(scenario.n_robots, scenario.n_tasks, np.array(table.nominal_time),
                                  tuple(t.service_time for t in scenario.tasks), tuple(scenario.predecessors),
                                  min_step, tuple(t.id for t in scenario.tasks), goal_timeout, precedence_margin,
                                  hold_successors, decision_mode)


@dataclass
class Plan:
    method: str
    robot_tasks: List[List[int]]                 # per robot, ordered task indices
    joint_actions: List[List[Optional[int]]]     # per step, task index or None per robot
    makespan: float                              # s, nominal, under the step rules
    logic_violations: int                        # tasks finished in wrong order (nominal)
    proven_optimal: bool = False
    details: Dict[str, Any] = field(default_factory=dict)
    instance: Optional[SchedulingInstance] = None   # what it was planned on (the replay's fallback uses it)

    def describe(self, task_ids: Sequence[str]) -> List[List[str]]:
        return [[task_ids[t] for t in tasks] for tasks in self.robot_tasks]

    @property
    def complete(self) -> bool:
        return self.instance is not None and sum(len(t) for t in self.robot_tasks) == self.instance.n_tasks

    @property
    def usable(self) -> bool:
        """Complete, in precedence order (margin included) and of finite makespan: a plan to run."""
        return self.complete and self.logic_violations == 0 and math.isfinite(self.makespan)

    @property
    def usable_makespan(self) -> float:
        """The makespan of a usable plan, else inf (a failure, in ratios)."""
        return self.makespan if self.usable else math.inf


class NominalRun:
    """Steps an instance with nominal travel times through model/rules.py (no noise, no episode
    timeout; a leg beyond the goal timeout fails as in the environment)."""

    def __init__(self, instance: SchedulingInstance):
        self.instance = instance
        self.positions = list(range(instance.n_robots))
        self.finished = [False] * instance.n_tasks
        self.elapsed = 0.0
        self.violations = 0
        self.robot_tasks: List[List[int]] = [[] for _ in range(instance.n_robots)]
        self.joint_actions: List[List[Optional[int]]] = []
        self.stalled = False   # the last step finished no task (next_goals then takes ready tasks only)
        # s, the least time between a predecessor's finish and its successor's arrival in one step
        # (inf when no step finishes both): how late a leg may run before the plan loses its order
        self.thinnest_margin = math.inf

    def preview(self, goals: Sequence[Optional[int]]) -> StepResolution:
        inst = self.instance
        legs = [0.0 if g is None else inst.travel_rows[self.positions[r]][inst.n_robots + g]
                for r, g in enumerate(goals)]
        reached = [g is not None and leg <= inst.goal_timeout for g, leg in zip(goals, legs)]
        nav = [leg if ok or g is None else inst.goal_timeout for g, leg, ok in zip(goals, legs, reached)]
        return resolve_step(goals, nav, reached, [0] * len(goals), self.finished,
                            inst.predecessors, inst.service, INFINITE_TIME, inst.min_step, inst.precedence_margin,
                            inst.hold_successors)

    def apply(self, goals: Sequence[Optional[int]]) -> StepResolution:
        resolution = self.preview(goals)
        for r, g in enumerate(goals):
            if g is not None and resolution.reached[r]:
                self.positions[r] = self.instance.n_robots + g
        finish_at = {done.task: done.finish_time for done in resolution.finished}
        for done in resolution.finished:
            for pred in self.instance.predecessors[done.task]:
                if pred in finish_at:
                    self.thinnest_margin = min(self.thinnest_margin, done.reach_time - finish_at[pred])
        for done in resolution.finished:
            self.finished[done.task] = True
            self.robot_tasks[done.robot].append(done.task)
            if not resolution.correct_order[done.robot]:
                self.violations += 1
        self.elapsed += resolution.duration
        self.joint_actions.append(list(goals))
        self.stalled = not resolution.finished
        return resolution

    @property
    def complete(self) -> bool:
        return all(self.finished)


def simulate_joint_actions(instance: SchedulingInstance, joint_actions: Sequence[Sequence[Optional[int]]]) -> NominalRun:
    run = NominalRun(instance)
    for goals in joint_actions:
        run.apply(goals)
    return run


def first_hop(instance: SchedulingInstance, finished: Sequence[bool], start: int, task: int) -> Optional[int]:
    """The task whose goal a robot at node `start` drives to first on its quickest way to `task`'s
    goal, when legs longer than the goal timeout force it over goals of finished tasks (a robot
    can only be sent to goals); `task` itself when the leg is feasible; None when no way exists."""
    target = instance.node(task)
    if instance.leg_feasible(start, target):
        return task
    rows = instance.travel_rows
    waypoints = [instance.node(j) for j in range(instance.n_tasks) if finished[j]] + [target]
    best = {start: 0.0}
    first: Dict[int, int] = {}
    queue = [(0.0, start)]
    while queue:
        time, node = heapq.heappop(queue)
        if node == target:
            return first[node] - instance.n_robots
        if time > best.get(node, math.inf):
            continue
        for nxt in waypoints:
            leg = rows[node][nxt]
            if nxt != node and leg <= instance.goal_timeout and time + leg < best.get(nxt, math.inf):
                best[nxt] = time + leg
                first[nxt] = first.get(node, nxt)
                heapq.heappush(queue, (time + leg, nxt))
    return None


def _claimed(goal: int, goals: Sequence[Optional[int]]) -> bool:
    """Whether some robot of `goals` is already sent to `goal`: a goal takes one robot, since a
    second would find the first standing on it and fail to reach it."""
    return goal in goals


def _one_per_goal(goals: List[Optional[int]]) -> List[Optional[int]]:
    """The goals with every robot but the first one sent to a goal waiting (None)."""
    return [None if g is not None and _claimed(g, goals[:r]) else g for r, g in enumerate(goals)]


def _ready(instance: SchedulingInstance, finished: Sequence[bool], task: int) -> bool:
    return not finished[task] and all(finished[p] for p in instance.predecessors[task])


def next_goals(run: NominalRun, robot_lists: Sequence[Sequence[int]]) -> Optional[List[Optional[int]]]:
    """One step of carrying out per-robot ordered task lists from the run's state, logic-consistent.

    Each robot heads for the first open task of its list (over goals of finished tasks when that
    leg is beyond the goal timeout; of robots headed for one goal the first goes, the others
    wait); a robot whose arrival would come before a predecessor is
    finished waits this step (None), repeatedly until the step is consistent. When that leaves
    every robot waiting (the lists order a task before a predecessor another robot holds
    later), each robot takes the first task of its list whose predecessors are all finished,
    and if none can, the robot nearest to a ready task no one else has takes it. Some task is
    always ready (the precedence is acyclic), so the lists never deadlock. After a step that
    finished nothing (`run.stalled`) robots take ready tasks only: a robot driving over other
    goals towards a task that is not ready can otherwise swing between two goals for ever, the
    way to its next ready task leading back where the way to its head came from. None: no robot
    can reach any ready task (the instance cannot be completed).
    """
    inst, finished, positions = run.instance, run.finished, run.positions

    def toward(robot: int, task: int) -> Optional[int]:
        return first_hop(inst, finished, positions[robot], task)

    heads = [next((t for t in tasks if not finished[t]), None) for tasks in robot_lists]
    goals = _one_per_goal([None if h is None or run.stalled else toward(r, h) for r, h in enumerate(heads)])
    while any(g is not None for g in goals):
        resolution = run.preview(goals)
        wrong = [r for r, g in enumerate(goals) if g is not None and not resolution.correct_order[r]]
        if not wrong:
            return goals
        for r in wrong:
            goals[r] = None
    taken = set()
    for r, tasks in enumerate(robot_lists):
        for t in tasks:
            if t not in taken and _ready(inst, finished, t):
                hop = toward(r, t)
                if hop is not None:
                    goals[r] = hop
                    taken.add(t)
                    break
    goals = _one_per_goal(goals)
    if any(g is not None for g in goals):
        return goals
    chains = inst.chain_times()
    spare = [t for t in range(inst.n_tasks) if _ready(inst, finished, t)]
    for t in spare:
        candidates = sorted((chains[positions[r], inst.node(t)], r) for r in range(inst.n_robots) if goals[r] is None)
        for _, r in candidates:
            hop = toward(r, t)
            if hop is not None and not _claimed(hop, goals):
                goals[r] = hop
                break
    return goals if any(g is not None for g in goals) else None


def decode_task_lists(instance: SchedulingInstance, robot_lists: Sequence[Sequence[int]]) -> NominalRun:
    """Joint actions carrying out per-robot ordered task lists (each task in exactly one list),
    step by step with next_goals, until every task is finished (or no robot can reach the rest).
    In event mode: the lists as routes dispatched on events (baselines/plan.py)."""
    if instance.decision_mode == "event":
        return decode_routes(instance, robot_lists)
    run = NominalRun(instance)
    # A bound on the steps, so that no list can keep the decoder going: every task is at most
    # n_tasks goals away from any robot and a stalled step moves towards a ready one.
    for _ in range(2 * (instance.n_tasks + 1) * (instance.n_tasks + instance.n_robots)):
        if run.complete:
            break
        goals = next_goals(run, robot_lists)
        if goals is None:
            break
        run.apply(goals)
    return run


def plan_from_run(method: str, run: NominalRun, **details: Any) -> Plan:
    return Plan(method, run.robot_tasks, run.joint_actions, run.elapsed, run.violations, details=dict(details),
                instance=run.instance)


def under_either_rules(solve: Callable[[SchedulingInstance], Plan], instance: SchedulingInstance) -> Plan:
    """A heuristic's plan for the instance; with the hold, the shorter of its plans under the hold
    and under the paper's rules, which keeps its makespan under the hold: the hold widens the
    search, and a heuristic does not always find the better plans in the wider one."""
    plan = solve(instance)
    if not instance.hold_successors or instance.decision_mode == "event":
        return plan
    paper = solve(dataclasses.replace(instance, hold_successors=False))
    return dataclasses.replace(paper, instance=instance) if paper.usable_makespan < plan.usable_makespan else plan

# ---------------------------------------------------------------------------- event mode
# Plans in event mode: per-robot routes carried out as event dispatch.
#
# Each robot takes the next task of its route the moment it comes free (model/event_rules.py): it
# drives there over the direct leg, waits there for the task's predecessors if they are not all
# finished, and serves it. With nominal legs that is the earliest-start schedule of the routes:
#
#     arrival(j) = finish(previous task of j's route) + leg(previous node, node of j)   (0 + leg from
#                  the robot's start for its first task)
#     start(j)   = max(arrival(j), finish of every predecessor of j)
#     finish(j)  = start(j) + service(j);   makespan = the last finish.
#
# Routes that wait on each other in a cycle (a robot holds at a task whose predecessor comes later
# on a route that waits in turn) never finish: such a plan is incomplete (makespan inf), as is one
# with a leg beyond the goal timeout (the environment fails it). test/python/test_event_mode.py checks this
# schedule against the environment's own episodes of the same routes.

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


def committed_first(instance: SchedulingInstance, routes: Sequence[Sequence[int]]) -> List[List[int]]:
    """The routes with each robot's committed task (a live fleet's) first on its own route and on
    no other: a robot cannot be planned away from what it is already doing."""
    committed = {instance.committed(r): r for r in range(instance.n_robots) if instance.committed(r) is not None}
    if not committed:
        return [list(route) for route in routes]
    fixed = [[t for t in route if t not in committed] for route in routes]
    for task, robot in committed.items():
        fixed[robot].insert(0, task)
    return fixed


def decode_routes(instance: SchedulingInstance, routes: Sequence[Sequence[int]]) -> EventRun:
    """The earliest-start schedule of `routes` (each task in at most one route); in a live fleet
    from each robot's ready time, no service before its task's release, and incomplete when a
    robot would finish a task after its deadline."""
    n_t = instance.n_tasks
    rows = instance.travel_rows
    if instance.live:
        routes = committed_first(instance, routes)
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
            arrival[task] = (finish[prev] if prev is not None else instance.ready_time(robot)) + leg
            start[task] = max([arrival[task], instance.release(task)] + [finish[p] for p in instance.predecessors[task]])
            finish[task] = start[task] + instance.service[task]
            if finish[task] > instance.deadline(robot) + 1e-9:   # the robot has left by then
                return EventRun(instance, lists, math.inf, False, arrival, start, finish)
            progressed = True
        if not progressed:   # routes that wait on each other: a deadlock
            return EventRun(instance, lists, math.inf, False, arrival, start, finish)
        pending = rest
    complete = all(f is not None for f in finish)
    makespan = max(finish) if complete and finish else (0.0 if n_t == 0 else math.inf)
    return EventRun(instance, lists, makespan, complete, arrival, start, finish)
