#!/usr/bin/env python3
"""rostest: rviz with the project's config draws the lab map, the robots and their scans.

rviz needs its X display before it starts, so this node runs the whole graph itself: it
starts Xvfb on a free display (Xvfb picks it: -displayfd), publishes the map latched (the
part navigation's map_server plays), starts ``~launch`` (sim.launch) with robots:=N
rviz:=true on that display, and, where nothing else does, publishes map -> <ns>/odom from
ground truth (the part localisation plays). It then takes screenshots (ImageMagick ``import -window root``)
until the render area shows the map cell for cell, each robot's blue body at its
ground-truth pose, and its scan, or the wait runs out; the last screenshot is kept.
"""
import math
import os
import shutil
import subprocess
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import OccupancyGrid, Odometry

from marl_mrta.model.occupancy_map import FREE, OCCUPIED, load_map
from marl_mrta.ros.process_group import stop_process_group
from marl_mrta.ros.rviz_config import COLOURS

BACKGROUND = np.array([48, 48, 48])        # rviz's default background colour (the config's)
# The LaserScan colours rviz_view gives robot i (scripts/rviz_view writes the team's config).
SCAN_RGB = {f"tb3_{i}": tuple(int(v) for v in colour.split(";")) for i, colour in enumerate(COLOURS)}
ROBOT_RADIUS = 0.105                       # m, TB3 Burger footprint
SCREEN = "1600x1000x24"


def pose_matrix(x, y, yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def planar_pose(odometry):
    p, q = odometry.pose.pose.position, odometry.pose.pose.orientation
    return p.x, p.y, math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y ** 2 + q.z ** 2))


def grab_screen(display, png_path):
    """Screenshot of the whole X screen as (rows, cols, 3) uint8; also saved as PNG."""
    env = dict(os.environ, DISPLAY=display)
    subprocess.run(["import", "-window", "root", png_path], env=env, check=True, timeout=60)
    ppm = subprocess.run(["convert", png_path, "-depth", "8", "ppm:-"], check=True,
                         capture_output=True, timeout=60).stdout
    magic, width, height, maxval, data = ppm.split(maxsplit=4)
    assert magic == b"P6" and maxval == b"255"
    return np.frombuffer(data, np.uint8, int(width) * int(height) * 3).reshape(
        int(height), int(width), 3)


class MapView:
    """Where the map is drawn on the screen: the bounding box of its white (free) pixels
    inside the render area (where rviz's background colour shows round the map)."""

    def __init__(self, image, grid_map):
        background = np.all(image == BACKGROUND, axis=2)
        # Rows/columns with many background pixels: the render area, not the colour swatch
        # of the Displays panel.
        rows = np.nonzero(background.sum(axis=1) >= 50)[0]
        cols = np.nonzero(background.sum(axis=0) >= 50)[0]
        self.found = rows.size > 100 and cols.size > 100
        if not self.found:
            return
        render = image[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
        white = np.nonzero(np.all(render >= 250, axis=2))
        self.found = white[0].size > 1000
        if not self.found:
            return
        self.top, self.left = rows.min() + white[0].min(), cols.min() + white[1].min()
        self.bottom, self.right = rows.min() + white[0].max(), cols.min() + white[1].max()
        self.map = grid_map
        self.pixels_per_metre = (self.right - self.left + 1) / (grid_map.width
                                                                * grid_map.resolution)

    def aspect_error(self):
        drawn = (self.right - self.left + 1) / (self.bottom - self.top + 1)
        return abs(drawn / (self.map.width / self.map.height) - 1.0)

    def to_pixel(self, x, y):
        """Screen (row, col) of world point (x, y) (map origin yaw 0, as the lab's)."""
        col = self.left + (x - self.map.origin.x) * self.pixels_per_metre
        row = self.bottom + 1 - (y - self.map.origin.y) * self.pixels_per_metre
        return int(row), int(col)


class RvizScreenshotTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("rviz_screenshot_test")
        cls.robots = ["tb3_%d" % i for i in range(rospy.get_param("~robots", 2))]
        cls.map = load_map(rospy.get_param("~map_yaml"))
        cls.screenshot = rospy.get_param("~screenshot", "/tmp/marl_mrta_rviz_screenshot.png")
        cls.wait = rospy.get_param("~wait", 150.0)
        for tool in ("Xvfb", "import", "convert", "roslaunch"):
            assert shutil.which(tool), f"{tool} is not installed"
        cls.processes = []
        cls.addClassCleanup(cls.stop_processes)   # also when set-up fails half-way
        cls.display = cls.start_xvfb()
        cls.map_publisher = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        cls.map_publisher.publish(cls.map_message())
        cls.ground_truth, cls.odometry = {}, {}
        cls.first_odometry = None
        for ns in cls.robots:
            rospy.Subscriber(f"/{ns}/base_pose_ground_truth", Odometry,
                             lambda msg, ns=ns: cls.ground_truth.__setitem__(ns, msg))
            rospy.Subscriber(f"/{ns}/odom", Odometry,
                             lambda msg, ns=ns: cls.odometry.__setitem__(ns, msg))
        launch = ["roslaunch", rospy.get_param("~launch"), f"robots:={len(cls.robots)}",
                  "rviz:=true"]
        cls.launch = subprocess.Popen(launch, env=dict(os.environ, DISPLAY=cls.display),
                                      start_new_session=True)
        cls.processes.append(cls.launch)
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)
        cls.static_tf = tf2_ros.StaticTransformBroadcaster()

    @classmethod
    def stop_processes(cls):
        for process in reversed(cls.processes):   # sim.launch first, then Xvfb
            stop_process_group(process)

    @classmethod
    def start_xvfb(cls):
        read_end, write_end = os.pipe()
        xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write_end), "-screen", "0", SCREEN,
                                 "-nolisten", "tcp"], pass_fds=(write_end,),
                                start_new_session=True, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        os.close(write_end)
        cls.processes.append(xvfb)
        with os.fdopen(read_end) as pipe:
            number = pipe.readline().strip()
        assert number, "Xvfb did not report a display number"
        rospy.loginfo("Xvfb on display :%s", number)
        return ":" + number

    @classmethod
    def map_message(cls):
        msg = OccupancyGrid()
        msg.header.frame_id = "map"
        msg.header.stamp = rospy.Time.now()
        msg.info.resolution = cls.map.resolution
        msg.info.width, msg.info.height = cls.map.width, cls.map.height
        msg.info.origin.position.x, msg.info.origin.position.y = cls.map.origin.x, cls.map.origin.y
        msg.info.origin.orientation.w = 1.0
        msg.data = cls.map.grid.ravel().tolist()
        return msg

    def localise(self):
        """map -> <ns>/odom from ground truth and odometry, for robots no one else localises
        (decided once the simulator has run a while, so its own transforms are known)."""
        if len(self.odometry) < len(self.robots):
            return False
        if self.first_odometry is None:
            self.first_odometry = time.monotonic()
        if time.monotonic() - self.first_odometry < 3.0:
            return False
        transforms = []
        for ns in self.robots:
            if self.tf_buffer.can_transform("map", f"{ns}/odom", rospy.Time(0)):
                continue
            if ns not in self.ground_truth or ns not in self.odometry:
                return False
            map_to_odom = pose_matrix(*planar_pose(self.ground_truth[ns])) @ np.linalg.inv(
                pose_matrix(*planar_pose(self.odometry[ns])))
            t = TransformStamped()
            t.header.stamp = rospy.Time.now()
            t.header.frame_id, t.child_frame_id = "map", f"{ns}/odom"
            t.transform.translation.x, t.transform.translation.y = map_to_odom[:2, 2]
            yaw = math.atan2(map_to_odom[1, 0], map_to_odom[0, 0])
            t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
            transforms.append(t)
        if transforms:
            self.static_tf.sendTransform(transforms)
            rospy.loginfo("published map -> odom for %s", [t.child_frame_id for t in transforms])
        return True

    def problems(self, image):
        """What the screenshot lacks; empty when map, robots and scans are all drawn."""
        view = MapView(image, self.map)
        if not view.found:
            return ["no map in the render area (no white free cells on rviz's background)"]
        found = []
        if view.aspect_error() > 0.03:
            found.append(f"map drawn with aspect off by {view.aspect_error():.1%}")
        robot_xy = [planar_pose(self.ground_truth[ns])[:2] for ns in self.robots]
        near_robot = lambda x, y, r: any(math.hypot(x - rx, y - ry) < r  # noqa: E731
                                         for rx, ry in robot_xy)
        # Map: every cell centre away from robots and not under a scan point shows black
        # (occupied) or white (free).
        compared = mismatched = 0
        for row in range(self.map.height):
            for col in range(self.map.width):
                x, y = self.map.cell_to_world(col, row)
                pixel = image[view.to_pixel(x, y)].astype(int)
                if near_robot(x, y, 0.45) or np.ptp(pixel) > 60:   # coloured: drawn over
                    continue
                expected = self.map.grid[row, col]
                compared += 1
                mismatched += (expected == OCCUPIED and pixel.mean() > 60) or \
                              (expected == FREE and pixel.mean() < 200)
        rospy.loginfo("map drawn at %.1f px/m, aspect off by %.2f%%; %d of %d cells in the "
                      "wrong shade", view.pixels_per_metre, 100 * view.aspect_error(), mismatched,
                      compared)
        if mismatched > 0.03 * compared:
            found.append(f"{mismatched} of {compared} map cells drawn in the wrong shade")
        # Robots: the model's blue body at each robot's pose, and nowhere else.
        rgb = image.astype(int)
        blue = (rgb[..., 2] > 150) & (rgb[..., 2] > rgb[..., 0] + 80) & \
            (rgb[..., 2] > rgb[..., 1] + 40)
        blue[:view.top] = blue[view.bottom + 1:] = False
        blue[:, :view.left] = blue[:, view.right + 1:] = False
        total_blue = int(blue.sum())
        radius_px = int(ROBOT_RADIUS * 1.5 * view.pixels_per_metre)
        on_robots = 0
        for ns, (x, y) in zip(self.robots, robot_xy):
            row, col = view.to_pixel(x, y)
            count = int(blue[max(row - radius_px, 0):row + radius_px,
                             max(col - radius_px, 0):col + radius_px].sum())
            on_robots += count
            rospy.loginfo("%s: %d blue pixels at its pose", ns, count)
            if count < 20:
                found.append(f"{ns}: robot model not drawn at ({x:.2f}, {y:.2f}) "
                             f"({count} blue pixels)")
        if total_blue - on_robots > 0.1 * max(on_robots, 1):
            found.append(f"{total_blue - on_robots} robot-coloured pixels away from the robots")
        # Scans: each robot's scan colour away from its robot (its odometry arrow shares it).
        for ns, (x, y) in zip(self.robots, robot_xy):
            colour = np.array(SCAN_RGB[ns])
            hits = np.all(np.abs(rgb - colour) < 30, axis=2)
            row, col = view.to_pixel(x, y)
            reach = int(0.5 * view.pixels_per_metre)
            hits[max(row - reach, 0):row + reach, max(col - reach, 0):col + reach] = False
            rospy.loginfo("%s: %d scan-coloured pixels", ns, int(hits.sum()))
            if int(hits.sum()) < 30:
                found.append(f"{ns}: scan not drawn ({int(hits.sum())} pixels of its colour)")
        return found

    def test_map_robots_and_scans_are_drawn(self):
        deadline = time.monotonic() + self.wait
        problems = ["no odometry and ground truth from every robot"]
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if self.launch.poll() is not None:
                problems = [f"the launch exited (status {self.launch.returncode})"]
                break
            if self.localise() and len(self.ground_truth) == len(self.robots):
                problems = self.problems(grab_screen(self.display, self.screenshot))
                if not problems:
                    break
                rospy.loginfo_throttle(10, "waiting for rviz: %s" % "; ".join(problems))
            time.sleep(2.0)   # wall clock: sim time may run at any rate
        rospy.loginfo("screenshot: %s", self.screenshot)
        self.assertEqual(problems, [], f"screenshot {self.screenshot}")


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "rviz_screenshot", RvizScreenshotTest)
