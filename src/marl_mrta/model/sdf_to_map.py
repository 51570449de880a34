"""Digitise simple SDF geometry (a building-model export) into a map_server occupancy map.

Input: an SDF file with a ``<world>`` (or bare ``<model>``s) of models, nested models and
links whose ``<collision>`` geometries are ``box``, ``cylinder`` or ``sphere``; ``plane``
geometries (ground planes) are ignored. Poses (``x y z roll pitch yaw``) of models, links and
collisions compose down the tree. Visuals are not obstacles and are ignored.

Output: the horizontal slice of all solids between ``z_min`` and ``z_max`` (the height band
the robot's body and lidar see, 0.05-0.5 m by default) projected onto a grid. A cell is
OCCUPIED when a solid overlaps the cell's column (cell x band) with positive volume, so thin
walls are never lost between cell centres and a wall ending exactly on a cell border does not
spill into the next cell. Everything else is FREE.

Errors (missing file, malformed XML, unsupported element, non-numeric or non-positive size)
raise ``SdfError`` whose message is one line naming the file, the element and the problem.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np

from marl_mrta.common.yaml_file import read_input_file
from marl_mrta.model.occupancy_map import FREE, MAX_MAP_CELLS, OCCUPIED, MapOrigin, OccupancyMap

# Solids must overlap a cell by more than this (metres) to occupy it: absorbs rounding in
# composed poses (cos(pi/2) = 6e-17) so borders that coincide with cell borders stay exact.
OVERLAP_TOLERANCE = 1e-6

SUPPORTED_GEOMETRY = ("box", "cylinder", "sphere", "plane")


class SdfError(ValueError):
    """Invalid or unsupported SDF input. The message is one line: file, element, problem."""


@dataclass(frozen=True)
class HeightBand:
    """Heights (m) whose obstacles go into the map."""

    z_min: float = 0.05
    z_max: float = 0.5


@dataclass(frozen=True)
class Transform:
    """A rigid transform: ``world_point = rotation @ local_point + translation``."""

    rotation: np.ndarray      # (3, 3)
    translation: np.ndarray   # (3,)

    @staticmethod
    def identity() -> "Transform":
        return Transform(np.eye(3), np.zeros(3))

    @staticmethod
    def from_pose(x, y, z, roll, pitch, yaw) -> "Transform":
        """SDF/URDF convention: fixed-axis roll about x, then pitch about y, then yaw about z."""
        cr, sr = math.cos(roll), math.sin(roll)
        cp, sp = math.cos(pitch), math.sin(pitch)
        cy, sy = math.cos(yaw), math.sin(yaw)
        rot_x = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
        rot_y = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
        rot_z = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
        return Transform(rot_z @ rot_y @ rot_x, np.array([x, y, z], dtype=float))

    def compose(self, child: "Transform") -> "Transform":
        """This transform followed by ``child`` expressed in this frame."""
        return Transform(self.rotation @ child.rotation,
                         self.rotation @ child.translation + self.translation)


@dataclass(frozen=True)
class BoxSolid:
    name: str                 # element path in the SDF, for messages
    pose: Transform           # world pose of the box centre
    size: np.ndarray          # (3,) full edge lengths along the box's own axes


@dataclass(frozen=True)
class CylinderSolid:
    name: str
    pose: Transform           # world pose of the centre; the axis is the local z axis
    radius: float
    length: float


@dataclass(frozen=True)
class SphereSolid:
    name: str
    pose: Transform
    radius: float


Solid = Union[BoxSolid, CylinderSolid, SphereSolid]


@dataclass(frozen=True)
class GridSpec:
    """Where the map lies: lower-left corner, cell size and number of cells."""

    origin_x: float
    origin_y: float
    resolution: float
    width: int
    height: int


# ---------------------------------------------------------------- parsing


def read_solids(sdf_path: Union[str, Path]) -> List[Solid]:
    """All collision solids of an SDF file, in world coordinates."""
    sdf_path = Path(sdf_path)
    text = read_input_file(sdf_path, SdfError, "file")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as err:
        raise SdfError(f"{sdf_path}: XML: {err}") from None
    if root.tag != "sdf":
        raise SdfError(f"{sdf_path}: <{root.tag}>: root element must be <sdf>")
    parser = _SdfReader(sdf_path)
    containers = root.findall("world") or [root]
    for container in containers:
        where = _label(container) if container is not root else "sdf"
        for child in container:
            if child.tag == "model":
                parser.model(child, Transform.identity(), where)
            elif child.tag == "include":
                raise parser.error(f"{where}/include", "unsupported element (inline the "
                                   "model's geometry instead)")
    if not parser.solids:
        raise SdfError(f"{sdf_path}: sdf: no collision geometry found")
    return parser.solids


def _label(element: ET.Element) -> str:
    name = element.get("name")
    return f"{element.tag}[{name}]" if name else element.tag


class _SdfReader:
    """Walks models -> links -> collisions, composing poses; collects solids."""

    def __init__(self, sdf_path: Path):
        self.sdf_path = sdf_path
        self.solids: List[Solid] = []

    def error(self, where: str, problem: str) -> SdfError:
        return SdfError(f"{self.sdf_path}: {where}: {problem}")

    def pose(self, element: ET.Element, where: str) -> Transform:
        pose = element.find("pose")
        if pose is None:
            return Transform.identity()
        if pose.get("relative_to"):
            raise self.error(f"{where}/pose", "attribute relative_to is not supported "
                             "(poses are relative to the parent element)")
        values = self.numbers(pose, f"{where}/pose", 6, allow_empty=True)
        return Transform.from_pose(*values) if values else Transform.identity()

    def numbers(self, element: Optional[ET.Element], where: str, count: int,
                allow_empty: bool = False) -> List[float]:
        if element is None:
            raise self.error(where, "missing")
        text = (element.text or "").strip()
        if not text and allow_empty:
            return []
        try:
            values = [float(token) for token in text.split()]
        except ValueError:
            raise self.error(where, f"expected {count} number(s), got {text!r}") from None
        if len(values) != count or not all(math.isfinite(v) for v in values):
            raise self.error(where, f"expected {count} number(s), got {text!r}")
        return values

    def positive(self, element: Optional[ET.Element], where: str, count: int) -> List[float]:
        values = self.numbers(element, where, count)
        if not all(v > 0.0 for v in values):
            raise self.error(where, f"must be positive, got {(element.text or '').strip()!r}")
        return values

    def model(self, model: ET.Element, parent: Transform, parent_where: str):
        where = f"{parent_where}/{_label(model)}"
        frame = parent.compose(self.pose(model, where))
        for child in model:
            if child.tag == "model":
                self.model(child, frame, where)
            elif child.tag == "link":
                self.link(child, frame, where)
            elif child.tag == "include":
                raise self.error(f"{where}/include", "unsupported element (inline the "
                                 "model's geometry instead)")

    def link(self, link: ET.Element, model_frame: Transform, model_where: str):
        where = f"{model_where}/{_label(link)}"
        frame = model_frame.compose(self.pose(link, where))
        for collision in link.findall("collision"):
            self.collision(collision, frame, where)

    def collision(self, collision: ET.Element, link_frame: Transform, link_where: str):
        where = f"{link_where}/{_label(collision)}"
        frame = link_frame.compose(self.pose(collision, where))
        geometry = collision.find("geometry")
        if geometry is None or len(geometry) != 1:
            raise self.error(f"{where}/geometry", "must hold exactly one shape")
        shape = geometry[0]
        shape_where = f"{where}/geometry/{shape.tag}"
        if shape.tag == "box":
            size = self.positive(shape.find("size"), f"{shape_where}/size", 3)
            self.solids.append(BoxSolid(where, frame, np.array(size)))
        elif shape.tag == "cylinder":
            (radius,) = self.positive(shape.find("radius"), f"{shape_where}/radius", 1)
            (length,) = self.positive(shape.find("length"), f"{shape_where}/length", 1)
            if abs(abs(frame.rotation[2, 2]) - 1.0) > 1e-9:
                raise self.error(shape_where, "only vertical cylinders are supported "
                                 "(roll/pitch tilt its axis)")
            self.solids.append(CylinderSolid(where, frame, radius, length))
        elif shape.tag == "sphere":
            (radius,) = self.positive(shape.find("radius"), f"{shape_where}/radius", 1)
            self.solids.append(SphereSolid(where, frame, radius))
        elif shape.tag != "plane":   # ground planes are the floor, not obstacles
            raise self.error(shape_where, f"unsupported geometry <{shape.tag}> (supported: "
                             f"{', '.join(SUPPORTED_GEOMETRY)})")


# ---------------------------------------------------------------- geometry


def _box_corners(box: BoxSolid) -> np.ndarray:
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return (box.pose.rotation @ (signs * box.size / 2.0).T).T + box.pose.translation


def solid_bounds(solid: Solid) -> Tuple[np.ndarray, np.ndarray]:
    """Axis-aligned world bounds (min xyz, max xyz) of a solid."""
    centre = solid.pose.translation
    if isinstance(solid, BoxSolid):
        corners = _box_corners(solid)
        return corners.min(axis=0), corners.max(axis=0)
    if isinstance(solid, CylinderSolid):
        half = np.array([solid.radius, solid.radius, solid.length / 2.0])
    else:
        half = np.full(3, solid.radius)
    return centre - half, centre + half


def _box_overlaps_columns(box: BoxSolid, centres_xy: np.ndarray, half_cell: float,
                          band: HeightBand) -> np.ndarray:
    """Separating-axis test of an oriented box against axis-aligned cell columns
    (cell x band); True where they overlap by more than OVERLAP_TOLERANCE on every axis."""
    axes_box = box.pose.rotation.T            # rows: the box's axes in world coordinates
    axes_world = np.eye(3)
    candidates = [*axes_world, *axes_box]
    for a in axes_world:
        for b in axes_box:
            cross = np.cross(a, b)
            norm = np.linalg.norm(cross)
            if norm > 1e-9:                   # parallel edges give no new axis
                candidates.append(cross / norm)
    column_half = np.array([half_cell, half_cell, (band.z_max - band.z_min) / 2.0])
    column_centres = np.column_stack([
        centres_xy, np.full(len(centres_xy), (band.z_max + band.z_min) / 2.0)])
    offsets = box.pose.translation - column_centres          # (n, 3)
    overlap = np.ones(len(centres_xy), dtype=bool)
    for axis in candidates:
        radius_box = np.sum(np.abs(axes_box @ axis) * box.size / 2.0)
        radius_column = np.sum(np.abs(axis) * column_half)
        distance = np.abs(offsets @ axis)
        overlap &= distance < radius_box + radius_column - OVERLAP_TOLERANCE
    return overlap


def _disc_overlaps_cells(centre_xy: np.ndarray, radius: float, centres_xy: np.ndarray,
                         half_cell: float) -> np.ndarray:
    """Whether a disc overlaps square cells with positive area (closest-point distance)."""
    nearest = np.clip(centre_xy, centres_xy - half_cell, centres_xy + half_cell)
    distance = np.linalg.norm(nearest - centre_xy, axis=1)
    return distance < radius - OVERLAP_TOLERANCE


def _band_overlap(z_low: float, z_high: float, band: HeightBand) -> bool:
    return min(z_high, band.z_max) - max(z_low, band.z_min) > OVERLAP_TOLERANCE


def solid_in_band(solid: Solid, band: HeightBand) -> bool:
    """Whether a solid reaches into the height band at all."""
    low, high = solid_bounds(solid)
    return _band_overlap(low[2], high[2], band)


def rasterise(solids: Sequence[Solid], spec: GridSpec, band: HeightBand) -> np.ndarray:
    """Occupancy grid (row 0 = lowest y) of the solids' slice through the height band."""
    grid = np.full((spec.height, spec.width), FREE, dtype=np.int8)
    half_cell = spec.resolution / 2.0
    for solid in solids:
        if not solid_in_band(solid, band):
            continue
        low, high = solid_bounds(solid)
        col_lo = max(int(math.floor((low[0] - spec.origin_x) / spec.resolution)) - 1, 0)
        col_hi = min(int(math.ceil((high[0] - spec.origin_x) / spec.resolution)) + 1, spec.width)
        row_lo = max(int(math.floor((low[1] - spec.origin_y) / spec.resolution)) - 1, 0)
        row_hi = min(int(math.ceil((high[1] - spec.origin_y) / spec.resolution)) + 1, spec.height)
        if col_lo >= col_hi or row_lo >= row_hi:
            continue
        rows, cols = np.mgrid[row_lo:row_hi, col_lo:col_hi]
        centres = np.column_stack([spec.origin_x + (cols.ravel() + 0.5) * spec.resolution,
                                   spec.origin_y + (rows.ravel() + 0.5) * spec.resolution])
        if isinstance(solid, BoxSolid):
            hit = _box_overlaps_columns(solid, centres, half_cell, band)
        else:
            centre = solid.pose.translation
            radius = solid.radius
            if isinstance(solid, SphereSolid):
                # The sphere's widest cross-section inside the band.
                nearest_z = min(max(centre[2], band.z_min), band.z_max)
                radius = math.sqrt(max(radius ** 2 - (centre[2] - nearest_z) ** 2, 0.0))
            hit = _disc_overlaps_cells(centre[:2], radius, centres, half_cell)
        grid[rows.ravel()[hit], cols.ravel()[hit]] = OCCUPIED
    return grid


# ---------------------------------------------------------------- the whole conversion


@dataclass(frozen=True)
class MapRequest:
    """How to digitise: cell size, height band, and where the map lies. ``origin`` (x, y) and
    ``size`` (width, height in metres) default to the bounds of the obstacles plus ``margin``."""

    resolution: float = 0.05
    band: HeightBand = HeightBand()
    margin: float = 0.5
    origin: Optional[Tuple[float, float]] = None
    size: Optional[Tuple[float, float]] = None


def grid_spec_for(solids: Sequence[Solid], request: MapRequest, source: str) -> GridSpec:
    """Place the grid: explicit origin/size, or the obstacles' bounds plus the margin."""
    if not request.resolution > 0.0:
        raise SdfError(f"{source}: resolution: must be positive, got {request.resolution}")
    if not request.band.z_max > request.band.z_min:
        raise SdfError(f"{source}: height band: z_max must exceed z_min, got "
                       f"{request.band.z_min}..{request.band.z_max}")
    in_band = [s for s in solids if solid_in_band(s, request.band)]
    if not in_band:
        raise SdfError(f"{source}: sdf: no collision geometry within the height band "
                       f"{request.band.z_min}..{request.band.z_max} m")
    lows, highs = zip(*(solid_bounds(s) for s in in_band))
    low = np.min(lows, axis=0)[:2] - request.margin
    high = np.max(highs, axis=0)[:2] + request.margin
    res = request.resolution
    if request.origin is not None:
        origin = np.array(request.origin, dtype=float)
    else:
        origin = np.floor(low / res + 1e-9) * res
    if request.size is not None:
        if not all(s > 0.0 for s in request.size):
            raise SdfError(f"{source}: size: must be positive, got {request.size}")
        cells = np.ceil(np.array(request.size) / res - 1e-9).astype(int)
    else:
        cells = np.ceil((high - origin) / res - 1e-9).astype(int)
        if not all(c > 0 for c in cells):
            raise SdfError(f"{source}: origin: the obstacles lie below/left of the origin "
                           f"({origin[0]}, {origin[1]})")
    if int(cells[0]) * int(cells[1]) > MAX_MAP_CELLS:   # the map loaders would refuse it
        raise SdfError(f"{source}: resolution: {res:g} m gives {int(cells[0])} x {int(cells[1])} cells, more than "
                       f"the {MAX_MAP_CELLS} a map may have")
    return GridSpec(float(origin[0]), float(origin[1]), res, int(cells[0]), int(cells[1]))


def sdf_to_occupancy_map(sdf_path: Union[str, Path], request: MapRequest = MapRequest()
                         ) -> OccupancyMap:
    """Read an SDF file and digitise it into an OccupancyMap (OCCUPIED / FREE)."""
    solids = read_solids(sdf_path)
    spec = grid_spec_for(solids, request, str(sdf_path))
    grid = rasterise(solids, spec, request.band)
    return OccupancyMap(grid=grid, resolution=spec.resolution,
                        origin=MapOrigin(spec.origin_x, spec.origin_y, 0.0))
