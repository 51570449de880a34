"""A live fleet in event mode: tasks released over time or submitted, cancelled, robots that leave or join.

A mixin of EventTaskEnvironment (env/event_env.py); model/event_rules.py holds the rules. Changes come
from two sources:
- the scenario: `<task release="t">` (unknown to every method before t) and `<faults>` (a robot
  leaves at t), applied as the episode's time reaches them;
- requests between two decision instants: submit(), cancel(), leave(), join() (the ROS task
  manager's services, ros/fleet_services.py; the executor's own report of a robot lost, with
  on_robot_fault continue). Each applies at the current instant and returns the output to
  decide on next (the robots it made due decide).

A submitted task gets a node in the travel table (planned on the map like the scenario's,
model/travel.py), a row in the observation (whose size then grows: a policy of fixed size cannot
act on it, the replanning allocator of baselines/replan.py can), and a goal for the executor (its
add_goals). Every request is checked before anything changes: a bad one raises FleetRequestError,
one line, and the schedule is as it was.

The record keeps what changed (EpisodeRecord.fleet_events: time, event, subject, detail) and when
each task became known (released_at), for the live fleet's figures (apps/bench_fleet.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import List, Optional, Sequence, Tuple

from marl_mrta.env.observation import ObservationEncoder
from marl_mrta.model.event_rules import DRIVING, LEFT, EventOutcome
from marl_mrta.model.occupancy_map import load_navigation_map
from marl_mrta.model.scenario import Pose2D, ScenarioError, TaskSpec, find_cycle, footprint_spacing, free_cell_problem
from marl_mrta.model.travel import nominal_travel_table


class FleetRequestError(ValueError):
    """A request the fleet refuses; str(error) is one line (which request, what is wrong)."""


@dataclass(frozen=True)
class TaskRequest:
    """A task submitted to a running episode: predecessors by id, among the open, finished or
    other submitted tasks."""

    id: str
    category: str
    x: float
    y: float
    yaw: float
    service_time: float = 0.0
    predecessors: Tuple[str, ...] = ()


#: The events of EpisodeRecord.fleet_events.
RELEASED, SUBMITTED, CANCELLED, LEFT_FLEET, JOINED, REFUSED = "released", "submitted", "cancelled", "left", "joined", "refused"


class LiveFleetMixin:
    """Live-fleet changes of EventTaskEnvironment; see the module docstring."""

    def _init_live(self, travel_model) -> None:
        self.travel_model = travel_model
        self._base_scenario = self.scenario
        self._table = None
        # Timed changes of the scenario: (time, order, kind, index), in time order.
        timed = [(t.release, 0, RELEASED, j) for j, t in enumerate(self.scenario.tasks) if t.release > 0.0]
        timed += [(f.at, 1, LEFT_FLEET, f.robot) for f in self.scenario.faults]
        self._timed = sorted(timed)
        #: Bumped at every change of the fleet (a release, request, robot lost): a planner re-plans.
        self.fleet_version = 0
        #: Called while the episode advances (the ROS task manager: a request is waiting); True ends
        #: the transition at the current instant so that requests apply between instants.
        self.interrupted = lambda: False

    def _initially_known(self) -> List[bool]:
        return [t.release <= 0.0 for t in self.scenario.tasks]

    def _restore_scenario(self) -> None:
        """A new episode starts from the scenario's own tasks (submitted ones dropped)."""
        if self.scenario is not self._base_scenario:
            self._set_scenario(self._base_scenario)

    def _live_reset(self) -> None:
        self._next_timed = 0
        self.fleet_version += 1
        self._leg_from: List[Optional[int]] = [None] * self.n_agents
        self.record.released_at = [0.0 if known else None for known in self.rules.known]
        self.record.fleet_events = []

    # ------------------------------------------------------------------ the table and nodes

    @property
    def table(self):
        """The nominal travel table of the episode's nodes (robots' starts, then every task's goal,
        submitted ones included): the planners' and the replanning allocator's."""
        executor_table = getattr(self.executor, "table", None)
        # Nodes of tasks added in an earlier episode stay at the end, unused: every index holds.
        if executor_table is not None and executor_table.n_nodes >= self.n_agents + self.n_tasks:
            return executor_table
        if self._table is None or self._table.n_nodes < self.n_agents + self.n_tasks:
            self._table = nominal_travel_table(self.scenario, self.travel_model)
        return self._table

    def robot_nodes(self) -> List[int]:
        """Per robot, the table node it stands on: the executor's where it knows them (embedded),
        else the node nearest to its pose (a robot stopped between nodes is planned from there)."""
        nodes = getattr(self.executor, "nodes", None)
        if callable(nodes):
            return list(nodes())
        poses = self.table.node_poses
        return [min(range(len(poses)), key=lambda k: math.hypot(poses[k][0] - x, poses[k][1] - y))
                for x, y, _ in self.executor.poses()]

    def leg_start_node(self, robot: int) -> Optional[int]:
        """The node a driving robot's current leg left from."""
        return self._leg_from[robot]

    def _note_dispatch(self, robot: int, node: int) -> None:
        self._leg_from[robot] = node

    # ------------------------------------------------------------------ timed changes

    def _next_timed_time(self) -> float:
        return self._timed[self._next_timed][0] if self._next_timed < len(self._timed) else math.inf

    def _apply_timed(self, now: float, outcome: EventOutcome) -> None:
        """The scenario's releases and faults due by `now`."""
        while self._next_timed < len(self._timed) and self._timed[self._next_timed][0] <= now + 1e-9:
            at, _, kind, index = self._timed[self._next_timed]
            self._next_timed += 1
            if kind == RELEASED:
                self.rules.release(index, now, outcome)
                self.record.released_at[index] = now
                self._log(now, RELEASED, self.scenario.tasks[index].id)
            elif self.rules.present(index):
                self._robot_leaves(index, now, f"fault at {at:g} s (scenario)", outcome)
            self.fleet_version += 1

    def _awaits_changes(self) -> bool:
        """A timed change is still to come."""
        return self._next_timed < len(self._timed)

    # ------------------------------------------------------------------ requests

    def submit(self, requests: Sequence[TaskRequest]):
        """Tasks added now; the output to decide on. FleetRequestError, nothing changed, when one
        is bad: a duplicate id, an unknown or cancelled predecessor, a cycle, a goal off the map,
        in an obstacle, on an unknown cell, on another open task's goal or out of every robot's reach."""
        self._check_running()
        if not requests:
            raise FleetRequestError("submit: no task given")
        tasks, predecessors = self._checked_submission(requests)
        scenario = replace(self.scenario, tasks=self.scenario.tasks + tuple(tasks),
                           predecessors=self.scenario.predecessors + tuple(predecessors))
        try:   # navigation's plans to and from the new goals: a goal no robot can reach fails here
            table = nominal_travel_table(scenario, self.travel_model)
        except ScenarioError as error:   # "FILE: <task id="X">: goal (x, y): PROBLEM"
            raise FleetRequestError("submit: " + str(error).split(": ", 1)[-1]) from None
        now = self.elapsed
        self._table = table
        self._set_scenario(scenario)
        if hasattr(self.executor, "add_goals"):
            self.executor.add_goals(scenario, table)
        outcome = EventOutcome(now)
        for task, preds in zip(tasks, predecessors):
            self.rules.add_task(preds, task.service_time, now, outcome)
            self.record.task_ids.append(task.id)
            self.record.task_logic_correct.append(None)
            self.record.released_at.append(now)
            self._log(now, SUBMITTED, task.id, f"({task.goal.x:g}, {task.goal.y:g})"
                      + (f" after {', '.join(scenario.tasks[p].id for p in preds)}" if preds else ""))
        return self._after_request(outcome)

    def cancel(self, task_id: str):
        """The task dropped now (never started); FleetRequestError when it is unknown, finished,
        already cancelled or in service."""
        self._check_running()
        task = self._task_of(task_id, "cancel")
        now = self.elapsed
        outcome = EventOutcome(now)
        driving = [r for r, state in enumerate(self.rules.robots) if state.task == task and state.phase == DRIVING]
        try:
            self.rules.cancel(task, now, outcome)
        except ValueError as problem:
            raise FleetRequestError(f"cancel {task_id}: {problem}") from None
        for robot in driving:
            self.executor.stop(robot)
        self._log(now, CANCELLED, task_id)
        return self._after_request(outcome)

    def leave(self, robot_id: str, reason: str = "operator"):
        """The robot out of the fleet now (its goal cancelled, its task back in the pool)."""
        self._check_running()
        robot = self._robot_of(robot_id, "leave")
        if not self.rules.present(robot):
            raise FleetRequestError(f"leave {robot_id}: has left already")
        outcome = EventOutcome(self.elapsed)
        self._robot_leaves(robot, self.elapsed, reason or "operator", outcome)
        return self._after_request(outcome)

    def join(self, robot_id: str):
        """A robot that had left back in the fleet now, idle where it stands."""
        self._check_running()
        robot = self._robot_of(robot_id, "join")
        try:
            self.rules.add_robot(robot, self.elapsed)
        except ValueError as problem:
            raise FleetRequestError(f"join {robot_id}: {problem}") from None
        self._log(self.elapsed, JOINED, robot_id)
        return self._after_request(EventOutcome(self.elapsed))

    def refuse(self, what: str, reason: str) -> None:
        """A refused request, kept in the record (the services answer it too)."""
        if self.record is not None:
            self._log(self.elapsed, REFUSED, what, reason)

    # ------------------------------------------------------------------ helpers

    def _robot_leaves(self, robot: int, now: float, reason: str, outcome: EventOutcome) -> None:
        task = self.rules.robots[robot].task
        if self.rules.remove_robot(robot, now, reason, outcome):
            self.executor.stop(robot)
        detail = reason + (f"; {self.scenario.tasks[task].id} back in the pool" if task is not None else "")
        self._log(now, LEFT_FLEET, self.scenario.robots[robot].id, detail)

    def _after_request(self, outcome: EventOutcome):
        self.fleet_version += 1
        for attempt in outcome.ended:
            self._record_attempt(attempt)
            self.record.nav_time[attempt.robot] += attempt.nav_time
        self.rules.last_event = self.elapsed
        return self.current_output()

    def _check_running(self) -> None:
        if self.record is None or self.over:
            raise FleetRequestError("no episode is running")

    def _task_of(self, task_id: str, verb: str) -> int:
        for index, task in enumerate(self.scenario.tasks):
            if task.id == task_id and self.rules.known[index]:
                return index
        raise FleetRequestError(f"{verb} {task_id}: no such task")

    def _robot_of(self, robot_id: str, verb: str) -> int:
        for index, robot in enumerate(self.scenario.robots):
            if robot.id == robot_id:
                return index
        raise FleetRequestError(f"{verb} {robot_id}: no such robot (the fleet: "
                                f"{', '.join(r.id for r in self.scenario.robots)})")

    def _checked_submission(self, requests: Sequence[TaskRequest]) -> Tuple[List[TaskSpec], List[Tuple[int, ...]]]:
        """The requests as tasks with predecessor indices (the new ones after the existing), or
        FleetRequestError naming the first bad one: ids and precedence first, then the goals."""
        index = {t.id: j for j, t in enumerate(self.scenario.tasks)}
        first_new = len(self.scenario.tasks)
        for k, request in enumerate(requests):
            if not request.id.strip():
                raise FleetRequestError(f"submit: task {k + 1}: an empty id")
            if request.id in index:
                raise FleetRequestError(f"submit {request.id}: duplicate id (a task of that id exists)")
            index[request.id] = first_new + k
        preds: List[Tuple[int, ...]] = []
        for k, request in enumerate(requests):
            mine: List[int] = []
            for name in request.predecessors:
                p = index.get(name)
                if p is None or (p < first_new and not self.rules.known[p]):
                    raise FleetRequestError(f"submit {request.id}: unknown predecessor '{name}'")
                if p < first_new and self.rules.cancelled[p]:
                    raise FleetRequestError(f"submit {request.id}: predecessor '{name}' was cancelled")
                if p == first_new + k:
                    raise FleetRequestError(f"submit {request.id}: a task cannot precede itself")
                if p not in mine:
                    mine.append(p)
            preds.append(tuple(mine))
        # Existing tasks never wait for new ones: a cycle can only run through the new ones.
        cycle = find_cycle([tuple(p - first_new for p in mine if p >= first_new) for mine in preds])
        if cycle:
            raise FleetRequestError("submit: precedence has a cycle: " + " -> ".join(requests[i].id for i in cycle))
        grid = self._grid_map()
        spacing = footprint_spacing()
        tasks: List[TaskSpec] = []
        for request in requests:
            where = f"submit {request.id}"
            if not all(math.isfinite(v) for v in (request.x, request.y, request.yaw, request.service_time)):
                raise FleetRequestError(f"{where}: pose and service_time must be finite numbers")
            if request.service_time < 0.0:
                raise FleetRequestError(f"{where}: service_time must not be negative, got {request.service_time:g}")
            if not request.category.strip():
                raise FleetRequestError(f"{where}: an empty category")
            goal = Pose2D(request.x, request.y, request.yaw)
            problem = free_cell_problem(grid, goal, "goal")
            if problem:
                raise FleetRequestError(f"{where}: {problem}")
            others = [(t.id, t.goal) for j, t in enumerate(self.scenario.tasks) if self.rules.open(j)]
            for other, pose in others + [(t.id, t.goal) for t in tasks]:
                apart = math.hypot(pose.x - goal.x, pose.y - goal.y)
                if apart < spacing:
                    raise FleetRequestError(f"{where}: goal ({goal.x:g}, {goal.y:g}) is closer than a robot's "
                                            f"footprint to the goal of task {other} ({apart:.3g} m apart, at least "
                                            f"{spacing:.3g} m needed)")
            tasks.append(TaskSpec(request.id, request.category, goal, float(request.service_time)))
        return tasks, preds

    def _grid_map(self):
        """The map as the scenario's goals were checked on (model/scenario.py)."""
        if getattr(self, "_grid", None) is None:
            self._grid = load_navigation_map(self.scenario.map_path)
        return self._grid

    def _set_scenario(self, scenario) -> None:
        """The episode's scenario (tasks added, or the initial one again at reset)."""
        self.scenario = scenario
        self.n_tasks = scenario.n_tasks
        self.n_actions = scenario.n_tasks + 1
        self.encoder = ObservationEncoder(scenario)
        self.obs_dim = self.encoder.obs_dim
        self.state_dim = self.encoder.state_dim
        self._goal_xy = [(t.goal.x, t.goal.y) for t in scenario.tasks]
        self._goal_pose = [(t.goal.x, t.goal.y, t.goal.yaw) for t in scenario.tasks]

    def _log(self, time: float, event: str, subject: str, detail: str = "") -> None:
        self.record.fleet_events.append({"time": round(time, 3), "event": event, "subject": subject,
                                         "detail": detail})

    def robot_left(self, robot: int) -> bool:
        return self.rules.robots[robot].phase == LEFT
