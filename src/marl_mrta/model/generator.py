"""Seeded scenario generator: maps, teams, tasks and precedence, written as files a user could write.

    from marl_mrta.model.generator import ScenarioRequest, generate_scenario
    scenario = generate_scenario(ScenarioRequest(n_robots=6, n_tasks=16, layout="rooms"), seed=3,
                                 out_dir=Path("/tmp/generated"), travel_model=model)

A scenario is drawn from a seed alone (the same request and seed give the same files):
- the map: one shipped with the package (maps/*.yaml, `layout="shipped"` or a map name), a
  map_server YAML file of the user's own floor (`layout="/path/floor.yaml"`, referred to by its
  absolute path, as map_server and the scenario loader read it), or a generated one written
  beside the scenario as map_server YAML + PGM: `rooms` (a grid of rooms with a door in every
  inner wall), `corridors` (a corridor with rooms off both sides) or `pillars` (a hall with
  square pillars);
- robot starts and task goals on free cells of the map's largest navigable region (at least
  `clearance` from any obstacle, more than navigation's inscribed radius), each at least
  `spacing` (a robot's footprint plus a margin) from every other pose;
- precedence: tasks in `stages` (categories A, B, C, ...), each task of a later stage after one
  or more tasks of the stage before, as `chains` (one predecessor, each used once), `forks` (one
  predecessor, shared), `joins` (two predecessors) or `mixed` (each task one of these);
- service times drawn from `service_times`.

The scenario is written as XML and read back with model/scenario.py's load_scenario, the same
validation as a user's file. With a travel model (config/task_embedded.yaml's, which the env
layer loads), its nominal travel table sets the r_nav thresholds (travel.suggest_nav_thresholds),
legs beyond `max_leg` make the generator draw the poses again, and the episode timeout is long
enough for any policy that finishes a task in every step: n_tasks × (longest leg + longest
service). Without one, straight-line estimates stand in for the travel times.
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import List, Optional, Sequence, Tuple
from xml.sax.saxutils import quoteattr

import numpy as np
from scipy import ndimage

from marl_mrta.common.paths import package_root
from marl_mrta.common.robot_names import default_robot_names
from marl_mrta.model.occupancy_map import (FREE, OCCUPIED, MapFileError, MapOrigin, OccupancyMap, load_map,
                                           load_navigation_map, save_map)
from marl_mrta.model.scenario import Scenario, ScenarioError, footprint_radius, footprint_spacing, load_scenario
from marl_mrta.model.travel import TravelModel, nominal_travel_table, suggest_nav_thresholds

LAYOUTS = ("rooms", "corridors", "pillars")
#: What a layout may be, for the command lines' help.
LAYOUT_HELP = ("rooms, corridors, pillars, shipped, a shipped map's name, or a map_server YAML file of your own "
               "floor (its scenarios refer to it by its absolute path)")
DAG_KINDS = ("chains", "forks", "joins", "mixed")
MIN_ROBOTS, MAX_ROBOTS = 2, 16
MIN_TASKS, MAX_TASKS = 4, 32
RESOLUTION = 0.05          # m per cell of generated maps, as the lab's
WALL = 0.15                # m, wall thickness of generated maps
DOOR = 1.0                 # m, door width: well above the robot's 0.21 m and navigation's inflation
ESTIMATED_SPEED = 0.22     # m/s, for straight-line estimates without a travel model
ESTIMATED_DETOUR = 1.3     # path length ÷ straight line, for those estimates
REGION_SHRINK = 0.85       # a floor's drawn part, per draw whose legs were too long (own maps)
# s: the longest nominal leg generate_scenarios and train_generalist keep by default (--max-leg). It
# was config/task.yaml's goal_timeout when that was a fixed 60 s; now a number of its own, so that
# the same seeds still draw the same scenarios whatever the goal timeout (auto by default) is.
DEFAULT_MAX_LEG = 60.0


class GeneratorError(ValueError):
    """A request that cannot be generated; str(error) is one line."""


@dataclass(frozen=True)
class ScenarioRequest:
    n_robots: int = 4
    n_tasks: int = 8
    layout: str = "rooms"                # rooms | corridors | pillars | shipped | a shipped map's name (lab)
                                         # | a map_server YAML file (a floor of one's own)
    width: float = 10.0                  # m, interior of a generated map
    height: float = 6.0                  # m
    dag: str = "mixed"                   # chains | forks | joins | mixed
    stages: int = 3                      # precedence depth (1: no precedence)
    service_times: Tuple[float, ...] = (0.0, 1.0, 2.0, 3.0)
    clearance: float = 0.35              # m from any obstacle to a start or goal
    spacing: float = 0.5                 # m between any two poses (at least the footprint)
    max_leg: Optional[float] = None      # s: redraw poses while a nominal leg is longer (DEFAULT_MAX_LEG, --max-leg)
    name: str = ""                       # default gen_<layout>_<robots>r<tasks>t_<seed>
    # The robots' navigation files (<robots navigation>; None: the package's). Left out of the
    # request's text, which seeds the draw: the same seed draws the same scenario with either.
    navigation: Optional[str] = field(default=None, repr=False)

    def check(self) -> None:
        if not MIN_ROBOTS <= self.n_robots <= MAX_ROBOTS:
            raise GeneratorError(f"robots: {self.n_robots} is not in {MIN_ROBOTS}..{MAX_ROBOTS}")
        if not MIN_TASKS <= self.n_tasks <= MAX_TASKS:
            raise GeneratorError(f"tasks: {self.n_tasks} is not in {MIN_TASKS}..{MAX_TASKS}")
        if (not is_map_file(self.layout) and self.layout not in LAYOUTS and self.layout != "shipped"
                and self.layout not in shipped_maps()):
            raise GeneratorError(f"layout: {self.layout!r} is not one of "
                                 f"{', '.join(LAYOUTS + ('shipped',) + tuple(shipped_maps()))} or a map YAML file")
        if self.dag not in DAG_KINDS:
            raise GeneratorError(f"dag: {self.dag!r} is not one of {', '.join(DAG_KINDS)}")
        if not 1 <= self.stages <= self.n_tasks:
            raise GeneratorError(f"stages: {self.stages} is not in 1..{self.n_tasks}")
        if self.width < 3.0 or self.height < 3.0:
            raise GeneratorError(f"map size: {self.width:g} x {self.height:g} m is below 3 x 3 m")
        if not self.service_times or min(self.service_times) < 0.0:
            raise GeneratorError("service_times: need at least one value, none negative")
        if self.spacing < footprint_spacing():
            raise GeneratorError(f"spacing: {self.spacing:g} m is below a robot's footprint ({footprint_spacing():g} m)")


def is_map_file(layout: str) -> bool:
    """A layout that names a map_server YAML file (a floor plan of one's own) rather than a kind."""
    return layout.endswith((".yaml", ".yml"))


def layout_name(layout: str) -> str:
    """The layout as a scenario name shows it: a map file by its stem (floor.yaml -> floor)."""
    return Path(layout).stem if is_map_file(layout) else layout


def shipped_maps() -> dict:
    """The maps shipped with the package: name -> YAML path (maps/*.yaml)."""
    return {p.stem: p for p in sorted((package_root() / "maps").glob("*.yaml"))}


# ------------------------------------------------------------------ maps

def _blank(width: float, height: float) -> Tuple[np.ndarray, float]:
    """A free grid of the interior plus walls around it; returns the grid and the wall in cells."""
    wall = int(round(WALL / RESOLUTION))
    cols = int(round(width / RESOLUTION)) + 2 * wall
    rows = int(round(height / RESOLUTION)) + 2 * wall
    grid = np.full((rows, cols), FREE, dtype=np.int8)
    grid[:wall, :] = grid[-wall:, :] = OCCUPIED
    grid[:, :wall] = grid[:, -wall:] = OCCUPIED
    return grid, wall


def _wall_with_door(grid: np.ndarray, rng: random.Random, fixed: int, lo: int, hi: int, vertical: bool,
                    thickness: int, door: int) -> None:
    """A wall along rows (vertical) or columns at index `fixed` from lo to hi, with one door."""
    start = rng.randint(lo + thickness, max(lo + thickness, hi - door - thickness))
    for k in range(lo, hi):
        if start <= k < start + door:
            continue
        if vertical:
            grid[k, fixed:fixed + thickness] = OCCUPIED
        else:
            grid[fixed:fixed + thickness, k] = OCCUPIED


def generate_map(layout: str, width: float, height: float, rng: random.Random) -> OccupancyMap:
    """A map of the layout with the given interior (m); origin at the outer walls' corner."""
    if layout not in LAYOUTS:
        raise GeneratorError(f"layout: {layout!r} is not one of {', '.join(LAYOUTS)}")
    grid, wall = _blank(width, height)
    rows, cols = grid.shape
    door = int(round(DOOR / RESOLUTION))
    if layout == "rooms":
        n_cols = max(1, int(width // 3.0))
        n_rows = max(1, int(height // 3.0))
        xs = [wall + int(round(i * (cols - 2 * wall) / n_cols)) for i in range(1, n_cols)]
        ys = [wall + int(round(i * (rows - 2 * wall) / n_rows)) for i in range(1, n_rows)]
        bounds_x = [wall] + xs + [cols - wall]
        bounds_y = [wall] + ys + [rows - wall]
        for x in xs:                          # one door per room along each vertical wall
            for a, b in zip(bounds_y[:-1], bounds_y[1:]):
                _wall_with_door(grid, rng, x - wall // 2, a, b, True, wall, door)
        for y in ys:
            for a, b in zip(bounds_x[:-1], bounds_x[1:]):
                _wall_with_door(grid, rng, y - wall // 2, a, b, False, wall, door)
    elif layout == "corridors":
        corridor = int(round(1.6 / RESOLUTION))
        middle = rows // 2
        low, high = middle - corridor // 2, middle + corridor // 2
        n_rooms = max(1, int(width // 3.0))
        xs = [wall + int(round(i * (cols - 2 * wall) / n_rooms)) for i in range(n_rooms + 1)]
        for y, a, b in ((low - wall, wall, low - wall), (high, high + wall, rows - wall)):
            for left, right in zip(xs[:-1], xs[1:]):   # the corridor's wall, a door into each room
                _wall_with_door(grid, rng, y, left, right, False, wall, door)
            for x in xs[1:-1]:                          # walls between rooms
                grid[a:b, x - wall // 2:x - wall // 2 + wall] = OCCUPIED
    else:
        side = int(round(0.4 / RESOLUTION))
        gap = int(round(2.0 / RESOLUTION))
        for row in range(wall + gap, rows - wall - side - gap // 2, gap + side):
            for col in range(wall + gap, cols - wall - side - gap // 2, gap + side):
                if rng.random() < 0.75:
                    dr, dc = rng.randint(-gap // 4, gap // 4), rng.randint(-gap // 4, gap // 4)
                    grid[row + dr:row + dr + side, col + dc:col + dc + side] = OCCUPIED
    return OccupancyMap(grid, RESOLUTION, MapOrigin(-WALL, -WALL, 0.0))


# ------------------------------------------------------------------ poses

def free_positions(grid_map: OccupancyMap, clearance: float, radius: float) -> np.ndarray:
    """(k, 2) world centres of the cells at least `clearance` from any obstacle (or unknown cell)
    within the largest region navigable for a robot of `radius` (8-connected cells farther than it)."""
    distance = grid_map.clearance()
    labels, count = ndimage.label(distance > radius + grid_map.resolution, structure=np.ones((3, 3)))
    if count == 0:
        return np.zeros((0, 2))
    sizes = ndimage.sum(np.ones_like(labels), labels, index=range(1, count + 1))
    main = labels == 1 + int(np.argmax(sizes))
    rows, cols = np.nonzero(main & (distance >= clearance))
    return np.column_stack(grid_map.cell_to_world(cols, rows))


def draw_poses(candidates: np.ndarray, count: int, spacing: float, rng: random.Random) -> List[Tuple[float, float, float]]:
    """`count` poses from the candidate points, pairwise at least `spacing` apart, yaw a multiple
    of π/2 (as a user places goals); GeneratorError when they do not fit."""
    order = list(range(len(candidates)))
    rng.shuffle(order)
    chosen: List[Tuple[float, float]] = []
    for index in order:
        x, y = float(candidates[index][0]), float(candidates[index][1])
        if all(math.hypot(x - a, y - b) >= spacing for a, b in chosen):
            chosen.append((round(x, 3), round(y, 3)))
            if len(chosen) == count:
                return [(x, y, rng.choice((0.0, 1.5708, 3.1416, -1.5708))) for x, y in chosen]
    raise GeneratorError(f"only {len(chosen)} of {count} poses fit {spacing:g} m apart on this map")


def part_of(candidates: np.ndarray, fraction: float, rng: random.Random) -> np.ndarray:
    """The candidate points within a disc about a random one of them, its radius `fraction` of
    half the candidates' extent (the diagonal of their bounding box)."""
    if len(candidates) == 0:
        return candidates
    centre = candidates[rng.randrange(len(candidates))]
    extent = float(np.hypot(*(candidates.max(axis=0) - candidates.min(axis=0))))
    return candidates[np.hypot(*(candidates - centre).T) <= fraction * extent / 2.0]


# ------------------------------------------------------------------ precedence

def stage_sizes(n_tasks: int, stages: int) -> List[int]:
    return [n_tasks // stages + (1 if s < n_tasks % stages else 0) for s in range(stages)]


def draw_precedence(sizes: Sequence[int], dag: str, rng: random.Random) -> List[List[int]]:
    """Predecessors per task (tasks numbered stage by stage), each edge from the stage before."""
    first = [sum(sizes[:s]) for s in range(len(sizes))]
    preds: List[List[int]] = [[] for _ in range(sum(sizes))]
    for s in range(1, len(sizes)):
        earlier = list(range(first[s - 1], first[s - 1] + sizes[s - 1]))
        unused = list(earlier)
        rng.shuffle(unused)
        for j in range(first[s], first[s] + sizes[s]):
            kind = rng.choice(DAG_KINDS[:3]) if dag == "mixed" else dag
            if kind == "chains":
                preds[j] = [unused.pop()] if unused else [rng.choice(earlier)]
            elif kind == "forks":
                preds[j] = [rng.choice(earlier)]
            else:
                preds[j] = sorted(rng.sample(earlier, min(2, len(earlier))))
    return preds


# ------------------------------------------------------------------ scenario files

def scenario_xml(name: str, map_file: str, robots: Sequence[Tuple[float, float, float]],
                 tasks: Sequence[Tuple[str, str, Tuple[float, float, float], float]],
                 preds: Sequence[Sequence[int]], timeout: float, nav: Tuple[float, float, float],
                 comment: str = "", navigation: Optional[str] = None) -> str:
    """The text of a scenario file (docs/reference/scenario_format.md)."""
    lines = ['<?xml version="1.0"?>']
    if comment:
        lines.append(f"<!-- {comment} -->")
    robots_tag = "  <robots>" if navigation is None else f"  <robots navigation={quoteattr(navigation)}>"
    lines += [f"<scenario name={quoteattr(name)}>", f"  <map file={quoteattr(map_file)}/>", robots_tag]
    lines += [f'    <robot id="{robot}" x="{x:g}" y="{y:g}" yaw="{yaw:g}"/>'
              for robot, (x, y, yaw) in zip(default_robot_names(len(robots)), robots)]
    lines += ["  </robots>", "  <tasks>"]
    lines += [f'    <task id="{tid}" category="{cat}" x="{x:g}" y="{y:g}" yaw="{yaw:g}" service_time="{service:g}"/>'
              for tid, cat, (x, y, yaw), service in tasks]
    lines.append("  </tasks>")
    edges = [(p, j) for j, ps in enumerate(preds) for p in ps]
    if edges:
        lines.append("  <precedence>")
        lines += [f'    <edge before="{tasks[p][0]}" after="{tasks[j][0]}"/>' for p, j in edges]
        lines.append("  </precedence>")
    lines += [f'  <episode timeout="{timeout:g}"/>',
              f'  <nav_time t_min="{nav[0]:g}" t_avg="{nav[1]:g}" t_max="{nav[2]:g}"/>', "</scenario>"]
    return "\n".join(lines) + "\n"


def _estimated_legs(poses: Sequence[Tuple[float, float, float]]) -> np.ndarray:
    xy = np.array([(p[0], p[1]) for p in poses])
    distance = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    return distance * ESTIMATED_DETOUR / ESTIMATED_SPEED + 2.0


def _timing(legs: np.ndarray, n_robots: int, services: Sequence[float]) -> Tuple[float, Tuple[float, float, float]]:
    """Episode timeout and r_nav thresholds from a leg table (nodes: starts, then goals)."""
    task_legs = legs[:, n_robots:]
    off = task_legs[~np.eye(legs.shape[0], dtype=bool)[:, n_robots:]]
    longest = float(off.max())
    timeout = 10.0 * math.ceil(len(services) * (longest + max(services)) / 10.0)
    nav = (math.floor(float(off.min()) * 2.0) / 2.0, round(float(off.mean()), 1), math.ceil(1.5 * longest * 2.0) / 2.0)
    return timeout, nav


def generate_scenario(request: ScenarioRequest, seed: int, out_dir: Path,
                      travel_model: Optional[TravelModel] = None, attempts: int = 20) -> Scenario:
    """Draw, write (<out_dir>/<name>.xml, a generated map under <out_dir>/maps/) and load one scenario."""
    request.check()
    # A map file seeds the draw by its name, not where it lies: the same floor and seed, the same draw.
    rng = random.Random(f"{seed}:{replace(request, layout=layout_name(request.layout))}")
    name = request.name or f"gen_{layout_name(request.layout)}_{request.n_robots}r{request.n_tasks}t_{seed}"
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    shipped = shipped_maps()
    if request.layout in LAYOUTS:
        grid_map = generate_map(request.layout, request.width, request.height, rng)
        (out_dir / "maps").mkdir(exist_ok=True)
        map_path = out_dir / "maps" / f"{name}.yaml"
        save_map(grid_map, map_path, comment=f"Generated by marl_mrta.model.generator: {request.layout}, seed {seed}.")
        map_file = f"maps/{name}.yaml"
    elif is_map_file(request.layout):
        map_path = Path(request.layout).resolve()
        try:
            grid_map = load_navigation_map(map_path)
        except MapFileError as error:
            raise GeneratorError(f"layout: {error}") from None
        map_file = str(map_path)
    else:
        key = rng.choice(sorted(shipped)) if request.layout == "shipped" else request.layout
        map_path = shipped[key]
        grid_map = load_map(map_path)
        map_file = f"package://marl_mrta/maps/{map_path.name}"
    candidates = free_positions(grid_map, request.clearance, footprint_radius())
    sizes = stage_sizes(request.n_tasks, request.stages)
    preds = draw_precedence(sizes, request.dag, rng)
    letters = [chr(ord("A") + s) for s in range(len(sizes))]
    labels = [(f"{letters[s]}{k + 1}", letters[s]) for s in range(len(sizes)) for k in range(sizes[s])]
    services = [rng.choice(request.service_times) for _ in labels]
    path = out_dir / f"{name}.xml"
    own_floor = is_map_file(request.layout)
    for attempt in range(attempts):
        # A floor of one's own cannot shrink as a generated map does: when its legs are too long,
        # the next draws keep to a smaller part of it (a disc about a random free cell).
        pool = candidates if attempt == 0 or not own_floor else part_of(candidates, REGION_SHRINK ** attempt, rng)
        try:
            poses = draw_poses(pool, request.n_robots + request.n_tasks, request.spacing, rng)
        except GeneratorError:
            if pool is candidates:
                raise
            continue
        robots, goals = poses[:request.n_robots], poses[request.n_robots:]
        tasks = [(tid, cat, goal, service) for (tid, cat), goal, service in zip(labels, goals, services)]
        timeout, nav = _timing(_estimated_legs(poses), request.n_robots, services)
        comment = f"generated by marl_mrta.model.generator from seed {seed}: {request}"
        path.write_text(scenario_xml(name, map_file, robots, tasks, preds, timeout, nav, comment, request.navigation))
        scenario = load_scenario(path)
        if travel_model is None:
            return scenario
        table = nominal_travel_table(scenario, travel_model)
        legs = table.nominal_time
        if request.max_leg is not None and float(legs[:, request.n_robots:].max()) > request.max_leg:
            continue
        timeout, _ = _timing(legs, request.n_robots, services)
        nav = suggest_nav_thresholds(table, request.n_robots)
        path.write_text(scenario_xml(name, map_file, robots, tasks, preds, timeout, nav, comment, request.navigation))
        return load_scenario(path)
    raise GeneratorError(f"{name}: no draw in {attempts} keeps every leg within {request.max_leg:g} s; "
                         "use a smaller map or a larger max_leg (--max-leg)")


def generate_scenarios(count: int, seed: int, out_dir: Path, base: ScenarioRequest = ScenarioRequest(),
                       travel_model: Optional[TravelModel] = None, keep: Sequence[str] = ()) -> List[Scenario]:
    """`count` scenarios from one seed, named <base.name or gen>_<k>. Per scenario the team size
    (2–16), task count (4–32), layout (generated or shipped), DAG kind, stages and map size are
    drawn, except the fields of `base` named in `keep`; a generated map's area grows with the
    team and tasks (about 0.9 m² per pose), so that legs stay short, and a draw whose map cannot
    keep every leg within base.max_leg is drawn again."""
    rng = random.Random(seed)
    scenarios = []
    for k in range(count):
        failure: Optional[GeneratorError] = None
        for draw in range(10):              # another draw when a map cannot keep legs within max_leg
            n_tasks = rng.randint(MIN_TASKS, MAX_TASKS)
            area = max(20.0, 0.9 * (n_tasks + n_tasks // 2))
            width = float(round(math.sqrt(1.6 * area)))
            drawn = dict(n_robots=rng.randint(MIN_ROBOTS, min(MAX_ROBOTS, max(MIN_ROBOTS, n_tasks // 2))),
                         n_tasks=n_tasks, layout=rng.choice(LAYOUTS + tuple(shipped_maps())), dag=rng.choice(DAG_KINDS),
                         stages=rng.randint(1, min(4, n_tasks)), width=width, height=float(max(4, round(area / width))))
            request = replace(base, **{key: value for key, value in drawn.items() if key not in keep},
                              name=f"{base.name or 'gen'}_{k:03d}")
            request = replace(request, stages=min(request.stages, request.n_tasks))
            try:
                scenarios.append(generate_scenario(request, seed * 100_003 + k * 101 + draw, out_dir, travel_model))
                break
            except ScenarioError as error:
                raise GeneratorError(f"scenario {k}: {error}") from None
            except GeneratorError as error:
                failure = error
        else:
            raise failure
    return scenarios
