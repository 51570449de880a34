"""The built-in navigation held against the stock stack on the same legs, without ROS.

What the harness (apps/bench_nav_vs_stock.py, ros/leg_runner.py) needs besides driving:
- the legs: seeded start/goal pairs on free cells of a map, away from obstacles and within the
  region a robot can reach (model/generator.py's free_positions), each with the noise seed the
  simulator's reset gets, so both stacks drive the same leg under the same noise;
- what one run recorded per leg (LegRecord) and its figures: path length from the ground truth,
  localisation error of the estimates against the ground truth at their stamps;
- the comparison per map: success rates, per-leg time ratio built-in ÷ stock (median, maximum)
  over the legs both stacks finished, the legs stock finished and the built-in did not;
- the acceptance goals (the built-in succeeds wherever stock does, median ratio at most 1.05,
  no leg above 1.5) as a list of what misses them, and the headline figures of the results file.

Times are seconds of simulated time, lengths metres, angles radians.
"""
from __future__ import annotations

import math
import random
import statistics
from dataclasses import asdict, dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

from marl_mrta.evaluation.sim_to_real import Track, localisation_errors
from marl_mrta.model.generator import free_positions
from marl_mrta.model.occupancy_map import OccupancyMap
from marl_mrta.model.scenario import footprint_radius

Pose = Tuple[float, float, float]

#: The acceptance goals (docs/guide/navigation.md).
MEDIAN_RATIO_GOAL = 1.05
MAX_RATIO_GOAL = 1.5
STACKS = ("builtin", "stock")


@dataclass(frozen=True)
class LegRequest:
    """How legs are drawn on a map."""

    count: int
    seed: int
    clearance: float = 0.35     # m from any obstacle or unknown cell to a start or goal
    min_distance: float = 1.0   # m, straight line between start and goal
    max_distance: float = 4.0   # m


@dataclass(frozen=True)
class LegTimings:
    """How long the harness's driver (ros/leg_runner.py) waits, and how close a re-initialised
    filter must come before a leg's goal is sent."""

    goal_timeout: float = 120.0             # s of sim time a goal may take before it counts as failed
    answer_wall: float = 5.0                # s of wall time a node may take to answer
    localization_wait: float = 10.0         # s of sim time for the filter to agree with the reset pose
    localization_tolerance: float = 0.10    # m and rad: "agrees"
    localization_settle: float = 0.6        # s of sim time after that (the filter's transform catches up)


@dataclass(frozen=True)
class Leg:
    start: Pose
    goal: Pose
    noise_seed: int   # the simulator's reset restarts the robot's noise streams from it

    def as_list(self) -> List[float]:
        """[sx, sy, syaw, gx, gy, gyaw, noise_seed]: how the driver node takes it as a parameter."""
        return [*self.start, *self.goal, self.noise_seed]

    @staticmethod
    def from_list(values: Sequence[float]) -> "Leg":
        if len(values) != 7:
            raise ValueError(f"a leg is [sx, sy, syaw, gx, gy, gyaw, noise_seed], got {list(values)}")
        return Leg(tuple(float(v) for v in values[:3]), tuple(float(v) for v in values[3:6]), int(values[6]))

    @property
    def straight_line(self) -> float:
        return math.hypot(self.goal[0] - self.start[0], self.goal[1] - self.start[1])


def draw_legs(grid_map: OccupancyMap, request: LegRequest) -> List[Leg]:
    """`request.count` legs from the seed alone: start and goal on cells at least `clearance` from
    any obstacle in the map's largest navigable region, their straight-line distance within
    [min_distance, max_distance], headings uniform in [-π, π). ValueError when the map has no
    such pair."""
    candidates = free_positions(grid_map, request.clearance, footprint_radius())
    if len(candidates) < 2:
        raise ValueError(f"fewer than two cells at least {request.clearance:g} m from every obstacle")
    rng = random.Random(request.seed)
    legs: List[Leg] = []
    for _ in range(request.count):
        for _attempt in range(10000):
            a, b = rng.randrange(len(candidates)), rng.randrange(len(candidates))
            (sx, sy), (gx, gy) = candidates[a], candidates[b]
            if request.min_distance <= math.hypot(gx - sx, gy - sy) <= request.max_distance:
                break
        else:
            raise ValueError(f"no start and goal {request.min_distance:g}-{request.max_distance:g} m apart")
        headings = [round(rng.uniform(-math.pi, math.pi), 4) for _ in range(2)]
        legs.append(Leg((round(float(sx), 3), round(float(sy), 3), headings[0]),
                        (round(float(gx), 3), round(float(gy), 3), headings[1]), rng.randrange(1 << 30)))
    return legs


#: Stock move_base (noetic-devel) can report a new goal reached at once where the robot stands: a
#: plan to the previous goal, finished after that goal's result, is taken for the new one
#: (ros-planning/navigation#949). Told by a success this soon after the goal, this far from it.
STALE_SUCCESS_WITHIN = 0.5   # s of sim time
STALE_SUCCESS_DISTANCE = 0.5  # m


def is_stale_success(succeeded: bool, elapsed: float, distance_to_goal: Optional[float]) -> bool:
    """A result that is the previous goal's plan (ros-planning/navigation#949), not this goal's."""
    return (succeeded and elapsed <= STALE_SUCCESS_WITHIN and distance_to_goal is not None
            and distance_to_goal > STALE_SUCCESS_DISTANCE)


def pose_at(track: Track, t: float) -> Optional[Tuple[float, float, float]]:
    """The last ground-truth pose at or before sim time `t` (None: none)."""
    before = [row for row in track if row[0] <= t + 1e-9]
    return tuple(before[-1][1:4]) if before else None


def path_length(track: Track, start: float, end: float) -> float:
    """m driven between sim times `start` and `end`: the polyline through the ground-truth poses."""
    points = [(x, y) for t, x, y, _ in track if start - 1e-9 <= t <= end + 1e-9]
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(points, points[1:]))


@dataclass(frozen=True)
class LocalisationFigures:
    """The estimates of one leg against the ground truth at their stamps."""

    estimates: int
    mean_xy: float
    max_xy: float
    mean_yaw: float
    max_yaw: float

    @staticmethod
    def of(estimates: Sequence[Tuple[float, float, float, float]], track: Track) -> Optional["LocalisationFigures"]:
        """`estimates`: (stamp, x, y, yaw). None when no estimate falls within the track."""
        errors = localisation_errors(estimates, track)
        if not errors:
            return None
        xy = [e[0] for e in errors]
        yaw = [e[1] for e in errors]
        return LocalisationFigures(len(errors), statistics.fmean(xy), max(xy), statistics.fmean(yaw), max(yaw))


@dataclass(frozen=True)
class LegRecord:
    """What one stack did on one leg."""

    index: int
    succeeded: bool
    outcome: str              # move_base's state and text, or "timeout"
    time: float               # s from the goal to its result (the timeout when there was none)
    path_length: float        # m driven meanwhile
    collisions: int = 0
    localisation: Optional[LocalisationFigures] = None
    filter_cpu: float = 0.0   # CPU s of the localisation node meanwhile
    filter_updates: int = 0   # estimates it published meanwhile (one per filter update)
    resent: int = 0           # times the goal was sent again after a stale success (is_stale_success)

    def to_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_dict(values: dict) -> "LegRecord":
        values = dict(values)
        if values.get("localisation") is not None:
            values["localisation"] = LocalisationFigures(**values["localisation"])
        return LegRecord(**values)


@dataclass(frozen=True)
class MapComparison:
    """Both stacks on the legs of one map, each leg driven the same number of times by each."""

    map: str
    legs: int
    success: Dict[str, float]                   # stack -> fraction of its drives that reached the goal
    ratios: List[Optional[float]]               # per leg, built-in ÷ stock median time; None unless both reached it
    stock_only: List[int] = field(default_factory=list)   # legs stock reached more often than the built-in

    @property
    def finished_ratios(self) -> List[float]:
        return [r for r in self.ratios if r is not None]

    @property
    def median_ratio(self) -> Optional[float]:
        return statistics.median(self.finished_ratios) if self.finished_ratios else None

    @property
    def max_ratio(self) -> Optional[float]:
        return max(self.finished_ratios) if self.finished_ratios else None

    def misses(self, median_goal: float = MEDIAN_RATIO_GOAL, max_goal: float = MAX_RATIO_GOAL) -> List[str]:
        """One line per goal this map misses (empty: all met)."""
        lines = [f"{self.map}: leg {i}: stock reached the goal more often than the built-in move_base"
                 for i in self.stock_only]
        if self.median_ratio is not None and self.median_ratio > median_goal:
            lines.append(f"{self.map}: median time ratio {self.median_ratio:.3f} above {median_goal:g}")
        lines += [f"{self.map}: leg {i}: time ratio {r:.3f} above {max_goal:g}"
                  for i, r in enumerate(self.ratios) if r is not None and r > max_goal]
        return lines

    def to_dict(self) -> dict:
        return {"map": self.map, "legs": self.legs, "success": self.success, "ratios": self.ratios,
                "median_ratio": self.median_ratio, "max_ratio": self.max_ratio, "stock_only": self.stock_only}


def _by_leg(records: Sequence[LegRecord], legs: int) -> List[List[LegRecord]]:
    drives: List[List[LegRecord]] = [[] for _ in range(legs)]
    for record in records:
        drives[record.index].append(record)
    return drives


def leg_time(drives: Sequence[LegRecord]) -> Optional[float]:
    """Median time of the drives of one leg that reached the goal (None: none did)."""
    times = [d.time for d in drives if d.succeeded]
    return statistics.median(times) if times else None


def compare_map(name: str, legs: int, runs: Dict[str, Sequence[LegRecord]]) -> MapComparison:
    """`runs`: stack name ("builtin", "stock") -> its records of the map's `legs` legs (LegRecord.index),
    any number of drives per leg, the same for both stacks."""
    builtin, stock = (_by_leg(runs[stack], legs) for stack in STACKS)
    if [len(d) for d in builtin] != [len(d) for d in stock]:
        raise ValueError(f"{name}: the two stacks did not drive the same legs as often")
    ratios = []
    for b, s in zip(builtin, stock):
        tb, ts = leg_time(b), leg_time(s)
        ratios.append(tb / ts if tb is not None and ts is not None and ts > 0.0 else None)
    stock_only = [i for i, (b, s) in enumerate(zip(builtin, stock))
                  if sum(d.succeeded for d in s) > sum(d.succeeded for d in b)]
    success = {stack: sum(r.succeeded for r in runs[stack]) / len(runs[stack]) if runs[stack] else 0.0
               for stack in STACKS}
    return MapComparison(name, legs, success, ratios, stock_only)


@dataclass(frozen=True)
class LocalisationSummary:
    """One stack's filter over every leg of a run."""

    legs: int
    estimates: int
    mean_xy: float
    max_xy: float
    mean_yaw: float
    max_yaw: float
    cpu_per_update: Optional[float]   # s of the node's CPU per filter update

    @staticmethod
    def of(records: Sequence[LegRecord]) -> Optional["LocalisationSummary"]:
        figures = [r.localisation for r in records if r.localisation is not None]
        if not figures:
            return None
        count = sum(f.estimates for f in figures)
        updates = sum(r.filter_updates for r in records)
        return LocalisationSummary(
            len(figures), count, sum(f.mean_xy * f.estimates for f in figures) / count, max(f.max_xy for f in figures),
            sum(f.mean_yaw * f.estimates for f in figures) / count, max(f.max_yaw for f in figures),
            sum(r.filter_cpu for r in records) / updates if updates else None)


def headline(navigation: Sequence[MapComparison], localisation: Dict[str, Dict[str, LocalisationSummary]]) -> List[dict]:
    """The results file's headline rows (tools/bench_table.py): per map the success rates and the
    median and maximum time ratio; per map and stack the localisation error and filter CPU."""
    rows: List[dict] = []
    for c in navigation:
        for stack in STACKS:
            rows.append({"figure": f"{c.map}: {stack} move_base success", "value": c.success.get(stack, 0.0),
                         "unit": "fraction", "goal": "built-in >= stock" if stack == "builtin" else ""})
        if c.median_ratio is not None:
            rows.append({"figure": f"{c.map}: time built-in / stock, median per leg", "value": c.median_ratio,
                         "unit": "ratio", "goal": f"<= {MEDIAN_RATIO_GOAL:g}"})
            rows.append({"figure": f"{c.map}: time built-in / stock, max per leg", "value": c.max_ratio,
                         "unit": "ratio", "goal": f"<= {MAX_RATIO_GOAL:g}"})
    for map_name, stacks in localisation.items():
        for stack, s in stacks.items():
            rows.append({"figure": f"{map_name}: {stack} amcl error, mean", "value": s.mean_xy, "unit": "m", "goal": ""})
            rows.append({"figure": f"{map_name}: {stack} amcl error, max", "value": s.max_xy, "unit": "m", "goal": ""})
            if s.cpu_per_update is not None:
                rows.append({"figure": f"{map_name}: {stack} amcl CPU per update", "value": s.cpu_per_update * 1e3,
                             "unit": "ms", "goal": ""})
    return rows
