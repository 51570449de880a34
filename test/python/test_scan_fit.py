"""How well a scan fits the map at an estimated pose (model/scan_fit.py), and the stop of a robot
whose scan keeps fitting badly (ros/safety.py): high where the robot is, low where it is not."""
import math

import numpy as np
import pytest

from marl_mrta.common.paths import package_root
from marl_mrta.model.occupancy_map import OCCUPIED, MapOrigin, OccupancyMap, load_map
from marl_mrta.model.scan_fit import MIN_RETURNS, ScanFit, grow, planar, quaternion_matrix, turn_rate
from marl_mrta.ros.safety import SafetyLimits, SafetyMonitor

LAB = package_root() / "maps" / "lab.yaml"
BEAMS = 360
RANGE_MAX = 3.5   # LDS-01


def cast(grid_map, x, y, yaw, range_max=RANGE_MAX):
    """A 360-beam scan from (x, y, yaw): each beam marched through the grid to its first occupied
    cell (a test's stand-in for the lidar; inf where nothing is within range_max)."""
    ranges = []
    for k in range(BEAMS):
        angle = yaw + 2.0 * math.pi * k / BEAMS
        r, hit = 0.0, math.inf
        while r < range_max:
            if grid_map.value_at(x + r * math.cos(angle), y + r * math.sin(angle)) == OCCUPIED:
                hit = r
                break
            r += grid_map.resolution / 4.0
        ranges.append(hit)
    return ranges


def fit_at(scan_fit, ranges, x, y, yaw):
    rotation, translation = planar(x, y, yaw)
    return scan_fit.fit(ranges, 0.0, 2.0 * math.pi / BEAMS, 0.12, RANGE_MAX, rotation, translation)


@pytest.fixture(scope="module")
def lab():
    return load_map(LAB)


@pytest.mark.parametrize("pose", [(0.5, 0.5, 0.0), (0.5, 4.5, 0.0), (1.0, 1.8, 0.4), (5.2, 3.3, 2.0)])
def test_a_scan_fits_where_it_was_taken(lab, pose):
    scan_fit = ScanFit(lab, tolerance=0.2)
    ranges = cast(lab, *pose)
    x, y, yaw = pose
    assert fit_at(scan_fit, ranges, x, y, yaw) > 0.95
    assert fit_at(scan_fit, ranges, x + 0.05, y - 0.05, yaw + 0.03) > 0.95   # amcl's usual error


@pytest.mark.parametrize("pose", [(1.0, 1.8, 0.4), (5.2, 3.3, 2.0)])
def test_a_scan_does_not_fit_a_metre_away(lab, pose):
    scan_fit = ScanFit(lab, tolerance=0.2)
    x, y, yaw = pose
    assert fit_at(scan_fit, cast(lab, *pose), x + 1.0, y, yaw) < 0.4


def test_a_scan_does_not_fit_a_quarter_turn_off_where_the_room_has_no_such_symmetry(lab):
    scan_fit = ScanFit(lab, tolerance=0.2)
    x, y, yaw = 1.0, 1.8, 0.4
    assert fit_at(scan_fit, cast(lab, x, y, yaw), x, y, yaw + math.pi / 2) < 0.1
    # In the middle of a room as wide as it is deep a quarter turn fits nearly as well: a scan
    # cannot tell poses the map cannot.
    assert fit_at(scan_fit, cast(lab, 2.5, 2.5, 1.0), 2.5, 2.5, 1.0 + math.pi / 2) > 0.6


def test_returns_on_another_robot_of_the_fleet_are_left_out(lab):
    scan_fit = ScanFit(lab, tolerance=0.2, robot_radius=0.105)
    world = OccupancyMap(grid=lab.grid.copy(), resolution=lab.resolution, origin=lab.origin)
    other = (1.3, 1.8)   # a Burger 0.3 m ahead of the robot, not in the map
    for row in range(world.height):
        for col in range(world.width):
            x, y = world.cell_to_world(col, row)
            if math.hypot(x - other[0], y - other[1]) <= 0.105:
                world.grid[row, col] = OCCUPIED
    ranges = cast(world, 1.0, 1.8, 0.0)
    rotation, translation = planar(1.0, 1.8, 0.0)
    seen_as_map = scan_fit.fit(ranges, 0.0, 2.0 * math.pi / BEAMS, 0.12, RANGE_MAX, rotation, translation)
    left_out = scan_fit.fit(ranges, 0.0, 2.0 * math.pi / BEAMS, 0.12, RANGE_MAX, rotation, translation, [other])
    assert seen_as_map < 0.9   # 41 degrees of the scan on the other robot
    assert left_out > 0.97


def test_beams_without_a_return_do_not_count_and_too_few_returns_say_nothing(lab):
    scan_fit = ScanFit(lab, tolerance=0.2)
    ranges = cast(lab, 2.5, 2.5, 0.0)
    returned = [i for i, r in enumerate(ranges) if math.isfinite(r)]
    assert len(returned) > MIN_RETURNS
    only_some = [r if i in returned[:MIN_RETURNS] else math.inf for i, r in enumerate(ranges)]
    assert fit_at(scan_fit, only_some, 2.5, 2.5, 0.0) > 0.95
    fewer = [r if i in returned[:MIN_RETURNS - 1] else RANGE_MAX for i, r in enumerate(ranges)]
    assert fit_at(scan_fit, fewer, 2.5, 2.5, 0.0) is None


def test_a_laser_mounted_upside_down_fits_through_its_full_rotation(lab):
    scan_fit = ScanFit(lab, tolerance=0.2)
    x, y, yaw = 0.5, 4.5, 0.3
    ranges = cast(lab, x, y, yaw)
    # Rolled by pi, the laser sweeps clockwise: its beam k points at yaw - angle_k in the map.
    flipped = [ranges[(-k) % BEAMS] for k in range(BEAMS)]
    rotation = planar(0.0, 0.0, yaw)[0] @ quaternion_matrix(1.0, 0.0, 0.0, 0.0)
    assert fit_at(scan_fit, ranges, x, y, yaw) > 0.95
    assert scan_fit.fit(flipped, 0.0, 2.0 * math.pi / BEAMS, 0.12, RANGE_MAX, rotation, (x, y, 0.2)) > 0.95


def test_quaternion_matrix_is_the_rotation_of_yaw_and_of_a_roll():
    yaw = 0.7
    assert np.allclose(quaternion_matrix(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)), planar(0.0, 0.0, yaw)[0])
    assert np.allclose(quaternion_matrix(1.0, 0.0, 0.0, 0.0), np.diag([1.0, -1.0, -1.0]))


def test_a_map_turned_by_its_origin_yaw_is_read_in_its_own_axes():
    grid = np.zeros((40, 40), dtype=np.int8)
    grid[:, 20] = OCCUPIED   # a wall along the map's own y axis, 1.0 m along its x axis
    turned = OccupancyMap(grid=grid, resolution=0.05, origin=MapOrigin(1.0, 2.0, math.pi / 2))
    scan_fit = ScanFit(turned, tolerance=0.1)
    # The map's x axis points along the world's y: the wall is the world line y = 3.025.
    assert scan_fit.near(np.array([0.0, -0.5]), np.array([3.02, 3.02])).tolist() == [True, True]
    assert scan_fit.near(np.array([0.0, 0.0]), np.array([2.7, 5.0])).tolist() == [False, False]


def test_grow_reaches_a_disc_of_the_radius():
    mask = np.zeros((11, 11), dtype=bool)
    mask[5, 5] = True
    grown = grow(mask, 2.5)
    rows, cols = np.nonzero(grown)
    assert set(zip(rows.tolist(), cols.tolist())) == {
        (r, c) for r in range(11) for c in range(11) if (r - 5) ** 2 + (c - 5) ** 2 <= 6.25}
    assert grow(mask, 0.5).sum() == 1


def test_a_tolerance_of_zero_is_refused(lab):
    with pytest.raises(ValueError, match="tolerance"):
        ScanFit(lab, tolerance=0.0)


# Silences never stop the fleet here: only the scan fit is under test.
LIMITS = SafetyLimits(odom_silent_after=1e9, scan_silent_after=1e9, move_base_silent_after=1e9,
                      scan_fit_min=0.5, scan_fit_lost_scans=10)


def armed_monitor():
    monitor = SafetyMonitor(["tb3_0", "tb3_1"], LIMITS)
    monitor.rearm(0.0)
    return monitor


def test_a_robot_whose_scans_fit_badly_the_limit_times_in_a_row_stops_the_fleet():
    monitor = armed_monitor()
    for k in range(1, 11):
        monitor.fitted(0, 0.9, 0.2 * k)
        monitor.fitted(1, 0.2 + 0.01 * k, 0.2 * k)
        reason = monitor.fault(0.2 * k)
        assert (reason == "") == (k < 10)
    assert reason == ("tb3_1: localisation lost: its last 10 scans fit the map at the estimated pose below 50 % "
                      "(1.8 s, the latest 30 %)")


def test_a_good_scan_in_between_starts_the_count_again_and_unjudged_scans_count_neither_way():
    monitor = armed_monitor()
    for k in range(9):
        monitor.fitted(0, 0.3, 0.2 * k)
    monitor.fitted(0, 0.8, 2.0)
    for k in range(9):
        monitor.fitted(0, 0.3, 2.2 + 0.2 * k)
        monitor.fitted(0, None, 2.3 + 0.2 * k)   # turning fast: not judged
    assert monitor.fault(5.0) == ""
    monitor.fitted(0, 0.3, 5.2)
    assert monitor.fault(5.2).startswith("tb3_0: localisation lost: its last 10 scans")


def test_a_lost_robot_cannot_start_an_episode_and_one_found_again_can():
    monitor = armed_monitor()
    for k in range(10):
        monitor.fitted(0, 0.1, 0.2 * k)
    assert monitor.check(2.0).startswith("tb3_0: localisation lost")
    assert monitor.rearm(3.0).startswith("tb3_0: localisation lost")
    monitor.fitted(0, 0.9, 3.1)   # the operator gave the right pose
    assert monitor.rearm(3.2) == ""


def test_a_minimum_of_zero_watches_nothing():
    monitor = SafetyMonitor(["tb3_0"], SafetyLimits(scan_fit_min=0.0))
    monitor.rearm(0.0)
    for k in range(100):
        monitor.fitted(0, 0.0, 0.2 * k)
    for part in ("odom", "scan", "move_base"):
        monitor.heard(0, part, 20.0)
    assert monitor.fault(20.0) == ""


def test_turn_rate_is_the_heading_change_over_the_window_across_pi():
    before = planar(0.0, 0.0, math.pi - 0.1)[0]
    now = planar(0.0, 0.0, -math.pi + 0.1)[0]
    assert turn_rate(before, now, 0.2) == pytest.approx(1.0)
    upside_down = quaternion_matrix(1.0, 0.0, 0.0, 0.0)
    assert turn_rate(upside_down, planar(0.0, 0.0, 0.3)[0] @ upside_down, 0.2) == pytest.approx(1.5)
