"""What planners work on and what they produce.

SchedulingInstance: a scenario reduced to nominal numbers (travel times between nodes, service
times, precedence). Plan: per-robot ordered task lists plus the per-step joint actions that
carry them out under the environment's step rules (model/rules.py), so a plan can be replayed
through the environment and scored by the same rules as every other method.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from marl_mrta.model.rules import StepResolution, resolve_step

INFINITE_TIME = math.inf


@dataclass(frozen=True)
class SchedulingInstance:
    """Nodes 0..n_robots−1 are the robots' start poses, node n_robots + j is task j's goal."""

    n_robots: int
    n_tasks: int
    travel: np.ndarray                          # (n_nodes, n_nodes) s, nominal leg times
    service: Tuple[float, ...]                  # per task, s
    predecessors: Tuple[Tuple[int, ...], ...]   # per task
    min_step: float = 1.0
    task_ids: Tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "travel_rows", np.asarray(self.travel, dtype=float).tolist())
        if not self.task_ids:
            object.__setattr__(self, "task_ids", tuple(f"T{j}" for j in range(self.n_tasks)))

    def node(self, task: int) -> int:
        return self.n_robots + task

    @staticmethod
    def from_scenario(scenario, table, min_step: float) -> "SchedulingInstance":
        return SchedulingInstance(scenario.n_robots, scenario.n_tasks, np.array(table.nominal_time),
                                  tuple(t.service_time for t in scenario.tasks), tuple(scenario.predecessors),
                                  min_step, tuple(t.id for t in scenario.tasks))


@dataclass
class Plan:
    method: str
    robot_tasks: List[List[int]]                 # per robot, ordered task indices
    joint_actions: List[List[Optional[int]]]     # per step, task index or None per robot
    makespan: float                              # s, nominal, under the step rules
    logic_violations: int                        # tasks finished in wrong order (nominal)
    proven_optimal: bool = False
    details: Dict[str, Any] = field(default_factory=dict)

    def describe(self, task_ids: Sequence[str]) -> List[List[str]]:
        return [[task_ids[t] for t in tasks] for tasks in self.robot_tasks]


class NominalRun:
    """Steps an instance with nominal travel times through model/rules.py (no noise, no timeout)."""

    def __init__(self, instance: SchedulingInstance):
        self.instance = instance
        self.positions = list(range(instance.n_robots))
        self.finished = [False] * instance.n_tasks
        self.elapsed = 0.0
        self.violations = 0
        self.robot_tasks: List[List[int]] = [[] for _ in range(instance.n_robots)]
        self.joint_actions: List[List[Optional[int]]] = []

    def preview(self, goals: Sequence[Optional[int]]) -> StepResolution:
        inst = self.instance
        nav = [0.0 if g is None else inst.travel_rows[self.positions[r]][inst.n_robots + g]
               for r, g in enumerate(goals)]
        return resolve_step(goals, nav, [g is not None for g in goals], [0] * len(goals), self.finished,
                            inst.predecessors, inst.service, INFINITE_TIME, inst.min_step)

    def apply(self, goals: Sequence[Optional[int]]) -> StepResolution:
        resolution = self.preview(goals)
        for r, g in enumerate(goals):
            if g is not None:
                self.positions[r] = self.instance.n_robots + g
        for done in resolution.finished:
            self.finished[done.task] = True
            self.robot_tasks[done.robot].append(done.task)
            if not resolution.correct_order[done.robot]:
                self.violations += 1
        self.elapsed += resolution.duration
        self.joint_actions.append(list(goals))
        return resolution

    @property
    def complete(self) -> bool:
        return all(self.finished)


def simulate_joint_actions(instance: SchedulingInstance, joint_actions: Sequence[Sequence[Optional[int]]]) -> NominalRun:
    run = NominalRun(instance)
    for goals in joint_actions:
        run.apply(goals)
    return run


def decode_task_lists(instance: SchedulingInstance, robot_lists: Sequence[Sequence[int]]) -> NominalRun:
    """Joint actions carrying out per-robot ordered task lists (each task in exactly one list).

    Each step every robot heads for the next task of its list; a robot whose arrival would
    come before a predecessor is finished waits this step instead (None), repeatedly until
    the step is consistent. If every remaining robot would have to wait, they go anyway (a
    logic violation, counted): the lists order some task before its own predecessor.
    """
    run = NominalRun(instance)
    pointer = [0] * instance.n_robots
    while any(pointer[r] < len(robot_lists[r]) for r in range(instance.n_robots)):
        wanted = [robot_lists[r][pointer[r]] if pointer[r] < len(robot_lists[r]) else None
                  for r in range(instance.n_robots)]
        goals = list(wanted)
        while True:
            resolution = run.preview(goals)
            wrong = [r for r, g in enumerate(goals) if g is not None and not resolution.correct_order[r]]
            if not wrong:
                break
            for r in wrong:
                goals[r] = None
        if all(g is None for g in goals):
            goals = wanted
        run.apply(goals)
        for r, g in enumerate(goals):
            if g is not None:
                pointer[r] += 1
    return run


def plan_from_run(method: str, run: NominalRun, **details: Any) -> Plan:
    return Plan(method, run.robot_tasks, run.joint_actions, run.elapsed, run.violations, details=dict(details))
