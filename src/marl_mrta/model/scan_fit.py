"""How well a laser scan fits the map at the pose localisation believes, without ROS.

A robot whose localisation went wrong while its filter stays confident (a wheel that slipped, a
robot lifted and set down elsewhere, a wrong pose estimate given in rviz) shows it in nothing but
its scan: the beams end where the map has no obstacle. amcl's covariance stays small then. The
fit is the share of a scan's returns that end within `tolerance` of an occupied cell of the map
when the scan is placed at the estimated pose; the real executor stops the fleet when one robot's
fit stays below a minimum (ros/safety.py). Returns that end on another robot of the fleet, where
its own localisation puts it, are left out: a robot close by fills a large share of a scan.
People and furniture that are not in the map lower the fit of a well-localised robot too, so the
minimum sits well below a clean scan's fit.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import numpy as np
from scipy import ndimage

from marl_mrta.model.occupancy_map import OCCUPIED, OccupancyMap

#: Fewer returns than this (a robot in an open hall, beyond the lidar's range) say nothing.
MIN_RETURNS = 30
#: How long before a scan's stamp its turn rate is measured from [s]: one turn of the LDS-01.
TURN_WINDOW = 0.2


class ScanFit:
    """The map's occupied cells grown by `tolerance` [m]; fit() places a scan on them. Robots of
    `robot_radius` [m] are where fit() is told the other robots are."""

    def __init__(self, occupancy_map: OccupancyMap, tolerance: float, robot_radius: float = 0.0):
        if not tolerance > 0.0:
            raise ValueError(f"tolerance must be > 0 m, got {tolerance!r}")
        self.occupancy_map = occupancy_map
        self.tolerance = tolerance
        self.robot_reach = robot_radius + tolerance
        # amcl's likelihood field also counts only OCCUPIED cells as obstacles.
        self.near_obstacle = grow(occupancy_map.grid == OCCUPIED, tolerance / occupancy_map.resolution)

    def fit(self, ranges: Sequence[float], angle_min: float, angle_increment: float, range_min: float,
            range_max: float, rotation: np.ndarray, translation: Sequence[float],
            other_robots: Sequence[Tuple[float, float]] = ()) -> Optional[float]:
        """The share of the scan's returns near an obstacle of the map, the laser frame placed in
        the map by `rotation` (3 x 3) and `translation` (3), leaving out returns on the robots at
        `other_robots` (x, y); None with fewer than MIN_RETURNS left. A beam at or beyond
        range_max, or below range_min, returned nothing."""
        r = np.asarray(ranges, dtype=float)
        angles = angle_min + angle_increment * np.arange(r.size)
        returned = np.isfinite(r) & (r >= range_min) & (r < range_max)
        r, angles = r[returned], angles[returned]
        in_laser = np.stack([r * np.cos(angles), r * np.sin(angles), np.zeros_like(r)])
        in_map = np.asarray(rotation, dtype=float) @ in_laser + np.asarray(translation, dtype=float).reshape(3, 1)
        xs, ys = in_map[0], in_map[1]
        for x, y in other_robots:
            off_robot = np.hypot(xs - x, ys - y) > self.robot_reach
            xs, ys = xs[off_robot], ys[off_robot]
        if xs.size < MIN_RETURNS:
            return None
        return float(self.near(xs, ys).mean())

    def near(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Whether each world point lies within the tolerance of an occupied cell (off the map: no)."""
        cols, rows, inside = self.occupancy_map.world_to_cells(xs, ys)
        result = np.zeros(xs.shape, dtype=bool)
        result[inside] = self.near_obstacle[rows[inside], cols[inside]]
        return result


def grow(mask: np.ndarray, radius_cells: float) -> np.ndarray:
    """`mask` grown by a disc of `radius_cells`: cells whose centre lies within that many cells of
    a set cell's centre."""
    if not mask.any():   # the transform would measure from outside the grid
        return mask.copy()
    return ndimage.distance_transform_edt(~mask) <= radius_cells


def planar(x: float, y: float, yaw: float):
    """rotation and translation of fit() for a laser level with the floor at (x, y, yaw)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), (x, y, 0.0)


def turn_rate(rotation_before: np.ndarray, rotation_now: np.ndarray, dt: float) -> float:
    """|rad/s| the laser turned about the vertical between two of its rotations `dt` s apart.
    A scan taken while the robot turns fast is smeared by the lidar's own turn and latency (its
    far returns land tens of centimetres off), so it says nothing about localisation."""
    before = math.atan2(rotation_before[1, 0], rotation_before[0, 0])
    now = math.atan2(rotation_now[1, 0], rotation_now[0, 0])
    return abs((now - before + math.pi) % (2.0 * math.pi) - math.pi) / dt


def quaternion_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """The rotation of a unit quaternion as a 3 x 3 matrix (a laser mounted upside down included)."""
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
