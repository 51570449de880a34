"""Nominal travel times between a scenario's poses, from the navigation idea on the same map.

The same chain the navigation stack uses, reduced to what a travel time needs:
1. costmap_2d: occupied (and unknown) cells lethal 254; cells within the robot's radius 253;
   out to the inflation radius 252·exp(−cost_scaling_factor·(d − radius)), with the inflation
   values of the navigation's own costmap file (config/nav/costmap_common_params_burger.yaml).
2. navfn: Dijkstra over the 8-connected grid with cell cost 50 + 0.8·cost (navfn's constants,
   as include/marl_mrta/nav/navfn_planner.h has them); cells of cost 253 and above are not
   traversable.
3. The cell path is straightened where a straight segment stays in cells no costlier than the
   path it replaces (navfn's gradient path is smooth, not a staircase), then measured.
4. time = initial turn / ω + length / v + final turn / ω (turning in place, as DWA does when
   the heading is far off), v the Burger's top speed (config/robot_burger.yaml), ω the turning
   speed the navigation achieves (config/task_embedded.yaml), at least `min_goal_time` (a goal at the robot's pose still costs a
   control cycle).

Nodes: the robots' start poses first (node r = robot r), then the task goals (node n_robots + j).
Tables are cached per (map file, poses, parameters) so environments built on the same
scenario share one computation.
"""
from __future__ import annotations

import math
import os
from dataclasses import astuple, dataclass
from typing import Callable, Dict, List, Sequence, Tuple

import numpy as np
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from marl_mrta.model.occupancy_map import FREE, OccupancyMap
from marl_mrta.model.scenario import Scenario, ScenarioError

LETHAL = 254
INSCRIBED = 253


#: navfn's cell cost: COST_NEUTRAL + COST_FACTOR·cost (NavfnPlanner::kCostNeutral, kCostFactor).
NAVFN_NEUTRAL_COST = 50.0
NAVFN_COST_FACTOR = 0.8


@dataclass(frozen=True)
class TravelModel:
    """Parameters of the travel-time model, each read from the file that owns it
    (env/settings.py: the robot file, the navigation's costmap file, config/task_embedded.yaml)."""

    inscribed_radius: float              # m, the robot's radius (config/robot_burger.yaml)
    inflation_radius: float              # m (config/nav/costmap_common_params_burger.yaml)
    cost_scaling_factor: float           # 1/m (the same file)
    linear_speed: float                  # m/s, the robot's top speed (config/robot_burger.yaml)
    angular_speed: float                 # rad/s, effective turning in place (config/task_embedded.yaml)
    min_goal_time: float                 # s (config/task_embedded.yaml)
    neutral_cost: float = NAVFN_NEUTRAL_COST
    cost_factor: float = NAVFN_COST_FACTOR


@dataclass
class TravelTable:
    """Pairwise nominal travel between nodes (robot starts, then task goals)."""

    node_poses: List[Tuple[float, float, float]]
    length: np.ndarray           # (n, n) m, path length
    turn_time: np.ndarray        # (n, n) s, initial + final turn in place
    nominal_time: np.ndarray     # (n, n) s
    paths: List[List[np.ndarray]]   # paths[a][b]: (k, 2) polyline a -> b in the map frame
    model: TravelModel
    map_bounds: Tuple[float, float, float, float]   # x, y of the map's lower-left corner, width, height (m)

    def __post_init__(self) -> None:
        # Plain lists: the executor reads single entries thousands of times per second.
        self.length_rows = self.length.tolist()
        self.turn_rows = self.turn_time.tolist()
        self.time_rows = self.nominal_time.tolist()

    @property
    def n_nodes(self) -> int:
        return len(self.node_poses)


class UnreachableGoal(ValueError):
    """A node that navigation could not plan to or from; carries the node index."""

    def __init__(self, node: int, message: str):
        super().__init__(message)
        self.node = node


def costmap(grid_map: OccupancyMap, model: TravelModel) -> np.ndarray:
    """costmap_2d's static + inflation layers over the whole map (uint8)."""
    obstacle = grid_map.grid != FREE          # occupied and unknown both block
    distance = ndimage.distance_transform_edt(~obstacle) * grid_map.resolution
    cost = np.zeros(grid_map.grid.shape, dtype=np.float64)
    ramp = (distance > model.inscribed_radius) & (distance <= model.inflation_radius)
    # costmap_2d truncates to unsigned char: (unsigned char)((253 − 1)·exp(...))
    cost[ramp] = np.floor((INSCRIBED - 1) * np.exp(-model.cost_scaling_factor
                                                   * (distance[ramp] - model.inscribed_radius)))
    cost[distance <= model.inscribed_radius] = INSCRIBED
    cost[obstacle] = LETHAL
    return cost.astype(np.uint8)


def _grid_graph(cost: np.ndarray, model: TravelModel) -> csr_matrix:
    """8-connected graph over traversable cells; edge weight = step length × mean cell cost."""
    rows, cols = cost.shape
    passable = cost < INSCRIBED
    cell_cost = model.neutral_cost + model.cost_factor * cost.astype(np.float64)
    index = np.arange(rows * cols).reshape(rows, cols)
    sources, targets, weights = [], [], []
    for d_row, d_col in ((0, 1), (1, 0), (1, 1), (1, -1)):
        r0, r1 = max(0, -d_row), rows - max(0, d_row)
        c0, c1 = max(0, -d_col), cols - max(0, d_col)
        a = (slice(r0, r1), slice(c0, c1))
        b = (slice(r0 + d_row, r1 + d_row), slice(c0 + d_col, c1 + d_col))
        ok = passable[a] & passable[b]
        step = math.hypot(d_row, d_col)
        w = step * 0.5 * (cell_cost[a] + cell_cost[b])
        sources.append(index[a][ok])
        targets.append(index[b][ok])
        weights.append(w[ok])
    src = np.concatenate(sources)
    dst = np.concatenate(targets)
    wts = np.concatenate(weights)
    n = rows * cols
    return csr_matrix((np.concatenate([wts, wts]), (np.concatenate([src, dst]), np.concatenate([dst, src]))),
                      shape=(n, n))


#: Sample fractions along a segment of `steps` steps, (steps + 1, 1): straightening measures
#: thousands of segments per table, of few distinct lengths.
_LINE_SAMPLES: Dict[int, np.ndarray] = {}
#: Shortcuts tried at once: most reach a few dozen cells before one is costlier than its section.
_SHORTCUT_BATCH = 32


def _line_samples(steps: int) -> np.ndarray:
    samples = _LINE_SAMPLES.get(steps)
    if samples is None:
        samples = _LINE_SAMPLES[steps] = np.linspace(0.0, 1.0, steps + 1)[:, None]
    return samples


def _line_max_costs(cost: np.ndarray, a: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Highest cell cost on each straight segment from cell centre `a` to a row of `ends` (row, col),
    sampled at twice the segment's longer extent in cells."""
    deltas = ends - a
    steps = np.abs(deltas).max(axis=1) * 2 + 1
    samples = [_line_samples(s) for s in steps.tolist()]
    lengths = steps + 1
    cells = np.rint(a + np.repeat(deltas, lengths, axis=0) * np.concatenate(samples)).astype(int)
    starts = np.concatenate(([0], np.cumsum(lengths)[:-1]))
    return np.maximum.reduceat(cost[cells[:, 0], cells[:, 1]], starts)


def straighten(cells: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Greedy shortcutting of a cell path (k, 2 as row, col): from each kept point, go to the
    farthest later point whose straight segment is no costlier than the path section it skips."""
    kept = [0]
    i = 0
    k = len(cells)
    path_cost = cost[cells[:, 0], cells[:, 1]]
    while i < k - 1:
        # The first later point whose segment is costlier than its section ends the shortcut
        # one point before it (the next point, i + 1, is always reachable).
        section_max = np.maximum.accumulate(path_cost[i:])   # [c - i]: the costliest of points i..c
        j = k - 1
        for first in range(i + 2, k, _SHORTCUT_BATCH):
            ends = np.arange(first, min(first + _SHORTCUT_BATCH, k))
            blocked = np.flatnonzero(_line_max_costs(cost, cells[i], cells[ends]) > section_max[ends - i])
            if blocked.size:
                j = int(ends[blocked[0]]) - 1
                break
        kept.append(j)
        i = j
    return cells[kept]


def _angle_diff(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


def build_travel_table(grid_map: OccupancyMap, poses: Sequence[Tuple[float, float, float]],
                       model: TravelModel) -> TravelTable:
    """Plan between every pair of poses; UnreachableGoal if one cannot be planned to."""
    cost = costmap(grid_map, model)
    graph = _grid_graph(cost, model)
    rows, cols = cost.shape
    cells = []
    for node, (x, y, _) in enumerate(poses):
        cell = grid_map.world_to_cell(x, y)
        if cell is None:
            raise UnreachableGoal(node, f"({x:g}, {y:g}) is off the map")
        if cost[cell.row, cell.col] >= INSCRIBED:
            raise UnreachableGoal(node, f"({x:g}, {y:g}) is within {model.inscribed_radius:g} m of an "
                                        "obstacle, where navigation cannot plan")
        cells.append(cell.row * cols + cell.col)
    _, predecessors = dijkstra(graph, directed=False, indices=cells, return_predecessors=True)
    n = len(poses)
    length = np.zeros((n, n))
    turn = np.zeros((n, n))
    paths: List[List[np.ndarray]] = [[np.zeros((0, 2))] * n for _ in range(n)]
    res = grid_map.resolution
    for a in range(n):
        for b in range(n):
            xa, ya, yaw_a = poses[a]
            xb, yb, yaw_b = poses[b]
            chain = [cells[b]]
            while chain[-1] != cells[a]:
                prev = predecessors[a, chain[-1]]
                if prev < 0:
                    raise UnreachableGoal(b, f"({xb:g}, {yb:g}) cannot be reached from ({xa:g}, {ya:g})")
                chain.append(prev)
            chain.reverse()
            chain_cells = np.array(chain)
            grid_path = np.column_stack((chain_cells // cols, chain_cells % cols))
            corner = straighten(grid_path, cost) if len(grid_path) > 1 else grid_path
            points = np.column_stack([grid_map.origin.x + (corner[:, 1] + 0.5) * res,
                                      grid_map.origin.y + (corner[:, 0] + 0.5) * res])
            # The exact poses replace the centres of their cells at both ends.
            points[0] = (xa, ya)
            points[-1] = (xb, yb)
            if len(points) == 1:
                points = np.array([(xa, ya), (xb, yb)])
            segments = np.diff(points, axis=0)
            seg_len = np.hypot(segments[:, 0], segments[:, 1])
            length[a, b] = float(seg_len.sum())
            moving = seg_len > 1e-9
            if moving.any():
                first = segments[np.argmax(moving)]
                last = segments[len(moving) - 1 - np.argmax(moving[::-1])]
                heading_in = math.atan2(first[1], first[0])
                heading_out = math.atan2(last[1], last[0])
                turn[a, b] = (_angle_diff(heading_in, yaw_a) + _angle_diff(yaw_b, heading_out)) / model.angular_speed
            else:
                turn[a, b] = _angle_diff(yaw_b, yaw_a) / model.angular_speed
            paths[a][b] = points
    nominal = np.maximum(turn + length / model.linear_speed, model.min_goal_time)
    bounds = (grid_map.origin.x, grid_map.origin.y, grid_map.width * res, grid_map.height * res)
    return TravelTable(list(poses), length, turn, nominal, paths, model, bounds)


_CACHE: Dict[tuple, TravelTable] = {}


def cached_travel_table(map_path: str, load_grid_map: Callable[[], OccupancyMap],
                        poses: Sequence[Tuple[float, float, float]], model: TravelModel) -> TravelTable:
    """build_travel_table, computed once per (map file state, poses, model) in this process."""
    stat = os.stat(map_path)
    key = (os.path.realpath(map_path), stat.st_mtime_ns, stat.st_size,
           tuple(tuple(float(v) for v in pose) for pose in poses), astuple(model))
    table = _CACHE.get(key)
    if table is None:
        table = build_travel_table(load_grid_map(), poses, model)
        _CACHE[key] = table
    return table


def suggest_nav_thresholds(table: TravelTable, n_robots: int) -> Tuple[float, float, float]:
    """t_min, t_avg, t_max for a scenario from its nominal legs (start -> task, task -> task):
    t_min = shortest leg, t_avg = mean leg, t_max = 1.5 × longest leg (docs/task_allocation.md)."""
    n = table.n_nodes
    legs = [table.nominal_time[a, b] for a in range(n) for b in range(n_robots, n) if a != b]
    return (math.floor(min(legs) * 2.0) / 2.0, round(float(np.mean(legs)), 1),
            math.ceil(1.5 * max(legs) * 2.0) / 2.0)


def scenario_poses(scenario: Scenario) -> List[Tuple[float, float, float]]:
    """The node poses of a scenario: robots' starts, then task goals."""
    return ([(r.start.x, r.start.y, r.start.yaw) for r in scenario.robots]
            + [(t.goal.x, t.goal.y, t.goal.yaw) for t in scenario.tasks])


def nominal_travel_table(scenario: Scenario, model: TravelModel) -> TravelTable:
    """The cached table of a scenario; ScenarioError naming the robot or task navigation cannot reach."""
    try:
        return cached_travel_table(str(scenario.map_path), scenario.load_map, scenario_poses(scenario), model)
    except UnreachableGoal as error:
        if error.node < scenario.n_robots:
            element = f"<robot id=\"{scenario.robots[error.node].id}\">"
            what = "start pose"
        else:
            element = f"<task id=\"{scenario.tasks[error.node - scenario.n_robots].id}\">"
            what = "goal"
        raise ScenarioError(f"{scenario.source}: {element}: {what} {error}") from None
