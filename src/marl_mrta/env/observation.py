"""Per-robot observation (paper Table 5, normalised) and the critic's global state.

Observation of robot i, in this order (every value in [0, 1] or a one-hot):
  step index / (2·n_tasks) (capped at 1)  ·  episode time / timeout
  pose at the step start: x, y (map-normalised), (cos yaw + 1)/2, (sin yaw + 1)/2   (z is 0 in 2D)
  robot id (one-hot, n_robots)
  current task and previous task (one-hot, n_tasks + 1; last = None)
  current goal and previous goal: x, y (map-normalised; None = where the robot stood)
  reached-goal flag of the current task
  category of the current task (one-hot over the scenario's categories + None)
  navigation duration and step duration of the last step / t_max (capped at 1)
  shared: finished flag per task, ready flag per task (open, every predecessor finished)
  shared: the other robots' x, y (in robot order)
Global state: every robot's observation, then episode time / timeout, step fraction, and per
task its finish time / timeout (0 while open) and its logic-correct flag.
"""
from __future__ import annotations

import copy
import math
import struct
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from marl_mrta.model.scenario import Scenario


class ObservationEncoder:
    def __init__(self, scenario: Scenario):
        self.n_robots = scenario.n_robots
        self.n_tasks = scenario.n_tasks
        self.timeout = scenario.episode_timeout
        self.t_max = scenario.nav_thresholds.t_max
        self.step_scale = 2.0 * scenario.n_tasks
        self.x0, self.y0, self.width, self.height = scenario.map_bounds
        categories = scenario.categories
        n_cat = len(categories)
        none_task = [0.0] * scenario.n_tasks + [1.0]
        self.task_onehot = [[1.0 if k == j else 0.0 for k in range(scenario.n_tasks + 1)]
                            for j in range(scenario.n_tasks)] + [none_task]
        self.category_onehot = [[1.0 if c == categories.index(t.category) else 0.0 for c in range(n_cat + 1)]
                                for t in scenario.tasks] + [[0.0] * n_cat + [1.0]]
        self.robot_onehot = [[1.0 if k == i else 0.0 for k in range(self.n_robots)] for i in range(self.n_robots)]
        self.others = [[k for k in range(self.n_robots) if k != i] for i in range(self.n_robots)]
        self.obs_dim = (2 + 4 + self.n_robots + 2 * (self.n_tasks + 1) + 4 + 1 + (n_cat + 1) + 2
                        + 2 * self.n_tasks + 2 * (self.n_robots - 1))
        # Where each part of a row starts (the set view reads rows by these offsets).
        self.at_pose = 2
        self.at_reached = 6 + self.n_robots + 2 * (self.n_tasks + 1) + 4
        self.at_durations = self.at_reached + 1 + n_cat + 1
        self.at_finished = self.at_durations + 2
        self.at_ready = self.at_finished + self.n_tasks
        self.at_others = self.at_ready + self.n_tasks
        self.state_dim = self.n_robots * self.obs_dim + 2 + 2 * self.n_tasks

    def xy(self, x: float, y: float) -> List[float]:
        return [(x - self.x0) / self.width, (y - self.y0) / self.height]

    def task_part(self, finished: Sequence[bool], ready: Sequence[bool], finish_time: Sequence[Optional[float]],
                  task_correct: Sequence[Optional[bool]]) -> Tuple[List[float], List[float]]:
        """What changes only when a task finishes, for encode(): the rows' finished and ready
        flags, and the state's finish times and logic-correct flags."""
        timeout = self.timeout
        shared = [*map(float, finished), *map(float, ready)]
        tail = ([0.0 if t is None else min(t / timeout, 1.0) for t in finish_time]
                + [1.0 if c else 0.0 for c in task_correct])
        return shared, tail

    def encode(self, step_index: int, elapsed: float, poses: Sequence[Tuple[float, float, float]],
               current_task: Sequence[Optional[int]], previous_task: Sequence[Optional[int]],
               current_goal: Sequence[Tuple[float, float]], previous_goal: Sequence[Tuple[float, float]],
               reached: Sequence[bool], last_nav: Sequence[float], last_step: float,
               tasks: Tuple[List[float], List[float]]) -> Tuple[np.ndarray, np.ndarray]:
        """Every robot's observation (n_robots, obs_dim) and the global state (state_dim,);
        tasks: task_part() of the episode as it stands."""
        n_tasks, t_max = self.n_tasks, self.t_max
        x0, y0, width, height = self.x0, self.y0, self.width, self.height
        shared, task_tail = tasks
        head = [min(step_index / self.step_scale, 1.0), min(elapsed / self.timeout, 1.0)]
        positions = [[(p[0] - x0) / width, (p[1] - y0) / height] for p in poses]
        step_norm = min(last_step / t_max, 1.0)
        task_onehot, category_onehot, robot_onehot, others = (self.task_onehot, self.category_onehot,
                                                               self.robot_onehot, self.others)
        # One flat list, converted once: the rows in robot order are the state's first part.
        values: List[float] = []
        for i in range(self.n_robots):
            yaw = poses[i][2]
            cur = current_task[i]
            cur = n_tasks if cur is None else cur
            prev = previous_task[i]
            prev = n_tasks if prev is None else prev
            goal, old_goal = current_goal[i], previous_goal[i]
            values += [*head, *positions[i], (math.cos(yaw) + 1.0) * 0.5, (math.sin(yaw) + 1.0) * 0.5,
                       *robot_onehot[i], *task_onehot[cur], *task_onehot[prev],
                       (goal[0] - x0) / width, (goal[1] - y0) / height,
                       (old_goal[0] - x0) / width, (old_goal[1] - y0) / height, 1.0 if reached[i] else 0.0,
                       *category_onehot[cur], min(last_nav[i] / t_max, 1.0), step_norm, *shared]
            for k in others[i]:
                values += positions[k]
        values += [head[1], head[0], *task_tail]
        state = float32_array(values)
        obs = state[:self.n_robots * self.obs_dim].reshape(self.n_robots, self.obs_dim).copy()
        return obs, state


_FLOAT32_PACKERS: Dict[int, struct.Struct] = {}


def float32_array(values: Sequence[float]) -> np.ndarray:
    """np.array(values, dtype=np.float32) at a third of its cost (every step's observations and
    rewards go through it): struct rounds each double to float32 by the same C cast. It refuses
    a value beyond float32's range, which numpy makes infinite: those take numpy's way."""
    packer = _FLOAT32_PACKERS.get(len(values))
    if packer is None:
        packer = _FLOAT32_PACKERS[len(values)] = struct.Struct(f"={len(values)}f")
    try:
        return np.frombuffer(bytearray(packer.pack(*values)), dtype=np.float32)
    except OverflowError:
        return np.array(values, dtype=np.float32)


# ----------------------------------------------------------------------------- the set view
#
# The same row, read as sets (the `set` actor, mappo/set_networks.py): a robot's row becomes
# features of the robot itself, one token per robot, one token per task, and the nominal travel
# time of every robot to every task. Robots stand on nodes of the travel-time table (start poses
# and task goals) when a step begins, so each robot's node is the node nearest to its position in
# the row; the table itself (model/travel.py) is known to every robot. Nothing in a token depends
# on a robot's or task's index, so the sizes of a scenario do not shape the network, and the rows
# may be padded to more robot and task slots than the scenario has (slots with valid = 0).
# In turn, a task's rivals are the robots still to choose; the claims (mappo/claims.py) add what the
# robots before chose. Who chooses when is the turn order (turn_ranks), a function of what every
# robot's row holds (positions, ready flags, the table), so each robot knows its place. Times are
# in units of the scenario's mean leg (start -> task and task -> task) and capped, so that
# scenarios of other sizes and maps look alike; lengths are in units of LENGTH_SCALE.

SELF_FEATURES = ("elapsed", "step", "done_share", "open_per_robot", "last_step", "last_nav", "reached",
                 "claimed_step")
ROBOT_FEATURES = ("valid", "is_self", "decided", "dx", "dy", "nearest_open")
TASK_FEATURES = ("valid", "finished", "ready", "claimed", "pending_predecessors", "open_successors", "depth",
                 "chain_time", "service", "my_time", "best_other_time", "lead", "closer_others", "dx", "dy",
                 "category", "claim_leg", "margin")
LENGTH_SCALE = 10.0   # m
TIME_CAP = 8.0        # mean legs: travel-time features saturate here
DEPTH_CAP = 8.0       # tasks: chains of open tasks longer than this look alike


#: The floor turned by quarter turns and mirrored (the eight symmetries of a square), as the
#: matrices that map the map's axes to the turned floor's: a set row's dx, dy are its only
#: features in the map's axes, so rows encoded under another orientation show a set actor the same
#: scenario on a turned floor, on which it may decide otherwise (evaluation/rollout.py tries each).
ORIENTATIONS = tuple(np.array(axes, dtype=np.float64).reshape(2, 2) for axes in (
    (1, 0, 0, 1), (0, -1, 1, 0), (-1, 0, 0, -1), (0, 1, -1, 0),     # turned by 0, 90, 180, 270 degrees
    (1, 0, 0, -1), (-1, 0, 0, 1), (0, 1, 1, 0), (0, -1, -1, 0)))    # mirrored on x, y and the diagonals


#: How robots take turns in a sequential decision (mappo/claims.py): index: robot 0 first;
#: nearest_ready: the robot with the shortest nominal leg to a ready task first.
TURN_ORDERS = ("index", "nearest_ready")


def feature(names: Sequence[str], name: str) -> int:
    return names.index(name)


def check_turn_order(turn_order: str) -> None:
    if turn_order not in TURN_ORDERS:
        raise ValueError(f"turn order {turn_order!r}: one of {', '.join(TURN_ORDERS)}")


def precedence_matrix(predecessors: Sequence[Sequence[int]], slots: Optional[int] = None) -> np.ndarray:
    """[task, predecessor] bool of per-task predecessor lists, padded to `slots` tasks."""
    m = len(predecessors) if slots is None else slots
    matrix = np.zeros((m, m), dtype=bool)
    for task, preds in enumerate(predecessors):
        matrix[task, [int(p) for p in preds]] = True
    return matrix


def turn_ranks(turn_order: str, travel: np.ndarray, ready: np.ndarray) -> np.ndarray:
    """Each robot's turn in a sequential decision (0 = first): travel (k, n, m) nominal times of
    every robot to every task, ready (k, m) bool -> ranks (k, n). nearest_ready: by the robot's
    shortest leg to a ready task, ties and robots with none by index. Why not index: a robot
    choosing early cannot take a task whose predecessor a later robot is about to claim
    (sequential_logic), which costs 4 % of the optimum on average (tools/mask_ceiling.py)."""
    travel, ready = np.asarray(travel, dtype=np.float64), np.asarray(ready, dtype=bool)
    k, n = travel.shape[:2]
    check_turn_order(turn_order)
    if turn_order == "index":
        return np.broadcast_to(np.arange(n), (k, n)).copy()
    legs = np.where(ready[:, None, :], travel, np.inf).min(axis=2, initial=np.inf)     # (k, n)
    order = np.lexsort((np.broadcast_to(np.arange(n), (k, n)), legs), axis=-1)          # by leg, then index
    ranks = np.empty((k, n), dtype=np.int64)
    np.put_along_axis(ranks, order, np.arange(n)[None, :].repeat(k, 0), axis=1)
    return ranks


class SetLayout:
    """Where the parts of a set row lie, for `robot_slots` robots and `task_slots` tasks: self
    features, robot tokens, task tokens, then travel times (robot slot major). Works on numpy
    arrays and torch tensors alike (slicing and reshape only)."""

    n_self, n_robot, n_task = len(SELF_FEATURES), len(ROBOT_FEATURES), len(TASK_FEATURES)

    def __init__(self, robot_slots: int, task_slots: int):
        self.robot_slots, self.task_slots = robot_slots, task_slots
        self.at_robots = self.n_self
        self.at_tasks = self.at_robots + robot_slots * self.n_robot
        self.at_travel = self.at_tasks + task_slots * self.n_task
        self.width = self.at_travel + robot_slots * task_slots

    @classmethod
    def of(cls, width: int, task_slots: int) -> "SetLayout":
        """The layout of rows `width` wide with `task_slots` task slots (the robot slots follow)."""
        robot_slots, rest = divmod(width - cls.n_self - task_slots * cls.n_task, cls.n_robot + task_slots)
        if rest or robot_slots < 1:
            raise ValueError(f"a set row of {width} values does not fit {task_slots} task slots")
        return cls(robot_slots, task_slots)

    def split(self, rows):
        """rows (..., width) -> self (..., S), robots (..., N, R), tasks (..., M, T), travel (..., N, M)."""
        lead = tuple(rows.shape[:-1])
        return (rows[..., :self.at_robots],
                rows[..., self.at_robots:self.at_tasks].reshape(*lead, self.robot_slots, self.n_robot),
                rows[..., self.at_tasks:self.at_travel].reshape(*lead, self.task_slots, self.n_task),
                rows[..., self.at_travel:].reshape(*lead, self.robot_slots, self.task_slots))

    def pad(self, rows: np.ndarray, to: "SetLayout") -> np.ndarray:
        """Rows (..., width) in the slots of `to` (at least as many): the added slots empty."""
        own, robots, tasks, travel = self.split(np.asarray(rows))
        lead = own.shape[:-1]
        out = np.zeros((*lead, to.width), dtype=np.float32)
        own_to, robots_to, tasks_to, travel_to = to.split(out)
        own_to[...] = own
        robots_to[..., :self.robot_slots, :] = robots
        tasks_to[..., :self.task_slots, :] = tasks
        travel_to[..., :self.robot_slots, :self.task_slots] = travel
        return out

    def state_width(self) -> int:
        """The critic's state: per robot slot its valid flag and self features, then robot 0's row."""
        return self.robot_slots * (1 + self.n_self) + self.width


class SetObservationEncoder:
    """Rows of a scenario's observations (ObservationEncoder) -> set rows (SetLayout)."""

    def __init__(self, flat: ObservationEncoder, scenario: Scenario, travel_time: np.ndarray,
                 node_poses: Sequence[Tuple[float, float, float]], turn_order: str = "index"):
        check_turn_order(turn_order)
        self.flat = flat
        self.turn_order = turn_order
        n, m = scenario.n_robots, scenario.n_tasks
        self.n_robots, self.n_tasks = n, m
        time = np.asarray(travel_time, dtype=np.float64)
        legs = time[:, n:][~np.eye(len(time), dtype=bool)[:, n:]]
        self.time_scale = float(legs.mean()) if legs.size else 1.0
        self.to_task = time[:, n:] / self.time_scale                  # (nodes, tasks)
        self.task_to_task = time[n:, n:] / self.time_scale
        self.node_xy = np.asarray(node_poses, dtype=np.float64)[:, :2]
        self.task_xy = self.node_xy[n:]
        self.precedes = precedence_matrix(scenario.predecessors)      # [task, predecessor]
        self.successors = [np.flatnonzero(self.precedes[:, j]) for j in range(m)]
        self.reverse_topological = _topological(scenario.predecessors)[::-1]
        self.service = np.array([t.service_time for t in scenario.tasks]) / self.time_scale
        categories = scenario.categories
        self.category = np.array([categories.index(t.category) / max(1, len(categories) - 1) for t in scenario.tasks])
        self.t_max = scenario.nav_thresholds.t_max
        self.orientation = 0

    def turned(self, orientation: int) -> "SetObservationEncoder":
        """This encoder with dx, dy on the floor turned by ORIENTATIONS[orientation] (0: as it is)."""
        if not 0 <= orientation < len(ORIENTATIONS):
            raise ValueError(f"orientation {orientation}: one of 0..{len(ORIENTATIONS) - 1}")
        encoder = copy.copy(self)
        encoder.orientation = orientation
        return encoder

    def _oriented(self, offsets: np.ndarray) -> np.ndarray:
        """Offsets (..., 2) in the map's axes -> the same on the encoder's floor."""
        return offsets if self.orientation == 0 else offsets @ ORIENTATIONS[self.orientation].T

    def robot_positions(self, rows: np.ndarray, robots: Sequence[int]) -> np.ndarray:
        """(k, n_robots, 2) metres: every robot's position as row r (robot robots[r]) sees it."""
        f = self.flat
        k, n = len(rows), self.n_robots
        scale = np.array([f.width, f.height])
        offset = np.array([f.x0, f.y0])
        xy = np.empty((k, n, 2))
        others = rows[:, f.at_others:f.at_others + 2 * (n - 1)].reshape(k, n - 1, 2)
        for r, robot in enumerate(robots):
            xy[r, robot] = rows[r, f.at_pose:f.at_pose + 2]
            xy[r, [i for i in range(n) if i != robot]] = others[r]
        return xy * scale + offset

    def nearest_nodes(self, xy: np.ndarray) -> np.ndarray:
        """(..., n_robots) the travel table's node nearest each position (..., n_robots, 2): where a
        robot stands in the table's terms (a start pose or a task's goal, within its tolerance)."""
        return np.argmin(((xy[..., None, :] - self.node_xy) ** 2).sum(-1), axis=-1)

    def encode(self, rows: np.ndarray, robots: Sequence[int], layout: SetLayout, sequential: bool) -> np.ndarray:
        """Set rows (k, layout.width) of observation rows (k, obs_dim) of robots `robots`;
        sequential: the robots decide in turn (turn_ranks; robot tokens say who decided before)."""
        f, n, m = self.flat, self.n_robots, self.n_tasks
        rows = np.asarray(rows, dtype=np.float64)
        k = len(rows)
        robots = np.asarray(robots, dtype=np.int64)
        finished = rows[:, f.at_finished:f.at_finished + m] > 0.5
        ready = rows[:, f.at_ready:f.at_ready + m] > 0.5
        open_ = ~finished
        xy = self.robot_positions(rows, robots)                                          # (k, n, 2)
        nodes = self.nearest_nodes(xy)
        travel = np.minimum(self.to_task[nodes], TIME_CAP)                               # (k, n, m)
        me = xy[np.arange(k), robots]                                                    # (k, 2)
        own = travel[np.arange(k), robots]                                               # (k, m)
        turn = turn_ranks(self.turn_order, self.to_task[nodes], ready)                   # (k, n)
        my_turn = turn[np.arange(k), robots][:, None]
        # The competition for a task: the robots still to choose (all others when choosing at once).
        rivals = turn > my_turn if sequential else np.arange(n)[None, :] != robots[:, None]
        rival_travel = np.where(rivals[:, :, None], travel, np.inf)                     # (k, n, m)
        others = np.minimum(rival_travel.min(axis=1), TIME_CAP)
        closer = (rival_travel < own[:, None, :]).sum(axis=1) / max(1, n - 1)
        depth, chain = self._chains(open_)

        out = np.zeros((k, layout.width), dtype=np.float32)
        own_self, robot_tokens, task_tokens, travel_out = layout.split(out)
        s = SELF_FEATURES
        own_self[:, feature(s, "step")] = rows[:, 0]
        own_self[:, feature(s, "elapsed")] = rows[:, 1]
        own_self[:, feature(s, "done_share")] = finished.mean(axis=1) if m else 0.0
        own_self[:, feature(s, "open_per_robot")] = np.minimum(open_.sum(axis=1) / n, 4.0) / 4.0
        durations = rows[:, f.at_durations:f.at_durations + 2] * self.t_max / self.time_scale
        own_self[:, feature(s, "last_nav")] = np.minimum(durations[:, 0], TIME_CAP)
        own_self[:, feature(s, "last_step")] = np.minimum(durations[:, 1], TIME_CAP)
        own_self[:, feature(s, "reached")] = rows[:, f.at_reached]

        r = ROBOT_FEATURES
        robot_tokens[:, :n, feature(r, "valid")] = 1.0
        robot_tokens[:, :n, feature(r, "is_self")] = np.arange(n)[None, :] == robots[:, None]
        if sequential:
            robot_tokens[:, :n, feature(r, "decided")] = turn < my_turn
        relative = self._oriented((xy - me[:, None, :]) / LENGTH_SCALE)
        robot_tokens[:, :n, feature(r, "dx")] = relative[..., 0]
        robot_tokens[:, :n, feature(r, "dy")] = relative[..., 1]
        nearest = np.where(open_[:, None, :], travel, np.inf).min(axis=2)
        robot_tokens[:, :n, feature(r, "nearest_open")] = np.where(np.isfinite(nearest), nearest, 0.0)

        t = TASK_FEATURES
        tasks = task_tokens[:, :m]
        tasks[..., feature(t, "valid")] = 1.0
        tasks[..., feature(t, "finished")] = finished
        tasks[..., feature(t, "ready")] = ready
        tasks[..., feature(t, "pending_predecessors")] = np.minimum(open_ @ self.precedes.T.astype(float), 4.0) / 4.0
        tasks[..., feature(t, "open_successors")] = np.minimum(open_ @ self.precedes.astype(float), 4.0) / 4.0
        tasks[..., feature(t, "depth")] = np.minimum(depth, DEPTH_CAP) / DEPTH_CAP
        tasks[..., feature(t, "chain_time")] = np.minimum(chain, TIME_CAP)
        tasks[..., feature(t, "service")] = np.minimum(self.service, TIME_CAP)
        tasks[..., feature(t, "my_time")] = own
        tasks[..., feature(t, "best_other_time")] = others
        tasks[..., feature(t, "lead")] = others - own
        tasks[..., feature(t, "closer_others")] = closer
        tasks[..., feature(t, "margin")] = TIME_CAP
        task_relative = self._oriented((self.task_xy[None] - me[:, None, :]) / LENGTH_SCALE)
        tasks[..., feature(t, "dx")] = task_relative[..., 0]
        tasks[..., feature(t, "dy")] = task_relative[..., 1]
        tasks[..., feature(t, "category")] = self.category
        travel_out[:, :n, :m] = travel
        return out

    def _chains(self, open_: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """Per row and task: the longest chain of open tasks that starts there (tasks) and its
        time (service times and legs between them, mean legs); 0 for a finished task."""
        k, m = open_.shape
        depth = np.zeros((k, m))
        chain = np.zeros((k, m))
        for j in self.reverse_topological:
            succ = self.successors[j]
            if len(succ):
                alive = open_[:, succ]
                depth[:, j] = 1.0 + np.where(alive, depth[:, succ], 0.0).max(axis=1)
                chain[:, j] = self.service[j] + np.where(alive, self.task_to_task[j, succ] + chain[:, succ], 0.0).max(axis=1)
            else:
                depth[:, j] = 1.0
                chain[:, j] = self.service[j]
        return depth * open_, chain * open_

    def state(self, set_rows: np.ndarray, layout: SetLayout) -> np.ndarray:
        """The critic's global state from the set rows (n_robots, width) of every robot (SetLayout.state_width)."""
        state = np.zeros(layout.state_width(), dtype=np.float32)
        per_robot = state[:layout.robot_slots * (1 + layout.n_self)].reshape(layout.robot_slots, 1 + layout.n_self)
        per_robot[:self.n_robots, 0] = 1.0
        per_robot[:self.n_robots, 1:] = set_rows[:, :layout.n_self]
        state[layout.robot_slots * (1 + layout.n_self):] = set_rows[0]
        return state


def _topological(predecessors: Sequence[Sequence[int]]) -> List[int]:
    """Task indices with every task after its predecessors (the scenario's precedence is a DAG)."""
    order: List[int] = []
    placed = [False] * len(predecessors)
    while len(order) < len(predecessors):
        for task, preds in enumerate(predecessors):
            if not placed[task] and all(placed[p] for p in preds):
                placed[task] = True
                order.append(task)
    return order
