#!/usr/bin/env python3
"""rostest loc_bad_input: bad input to the built-in amcl (marl_mrta/amcl) on the lab map.

- An initial pose in the parameters off the map or inside an obstacle: the node exits 1 with
  one FATAL line naming the robot's parameters, the pose and the problem (stock amcl would
  start its filter there).
- A malformed initial pose in the parameters (NaN, or not a number): exit 1, one FATAL line
  naming the parameter and the value (stock amcl would take NaN and spread NaN particles).
- A parameter file with an unknown key (test/data/loc/bad_unknown_key.yaml over TurtleBot3's
  file): exit 1, one FATAL line naming the key (stock amcl ignores it).
- An `initialpose` message inside an obstacle: one warning naming the topic, the pose ignored
  (the node keeps running, and takes the next good pose).

Each case runs the amcl binary against the test's master as `<robot>/amcl`, with the parameters
robot_nav.launch gives it (config/nav/amcl_params.yaml, the robot's frames, the initial pose); the
map comes from the map_server of the .test file. What the node logs is read from its own output
(its first lines are published before the node's connection to /rosout exists, so never get
there).
"""
import os
import re
import subprocess
import threading
import time
import unittest
from collections import deque

import rospkg
import rospy
import rostest
import yaml
from geometry_msgs.msg import PoseWithCovarianceStamped
from roslib.packages import find_node

ANSI = re.compile(r"\x1b\[[0-9;]*m")
BAD_OUTPUT = ("Traceback", "terminate called", "what():", "Segmentation")


class AmclBadInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("loc_bad_input_test")
        cls.package = rospkg.RosPack().get_path("marl_mrta")
        cls.binary = find_node("marl_mrta", "amcl")[0]

    def parameters(self, robot, x, y, extra_file=None):
        with open(os.path.join(self.package, "config", "nav", "amcl_params.yaml")) as f:
            params = yaml.safe_load(f)
        params.update({"odom_frame_id": robot + "/odom", "base_frame_id": robot + "/base_footprint",
                       "global_frame_id": "map", "initial_pose_x": x, "initial_pose_y": y, "initial_pose_a": 0.0})
        if extra_file:
            with open(os.path.join(self.package, "test", "data", "loc", extra_file)) as f:
                params.update(yaml.safe_load(f))
        rospy.set_param("/%s/amcl" % robot, params)

    def start(self, robot):
        # Line-buffered: the output is read while the node runs.
        return subprocess.Popen([self.binary, "__name:=amcl", "__ns:=" + robot, "map:=/map"], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, universal_newlines=True,
                                env=dict(os.environ, ROSCONSOLE_STDOUT_LINE_BUFFERED="1"))

    def assert_exits_with_one_fatal_line(self, robot, expected):
        process = self.start(robot)
        output, _ = process.communicate(timeout=60)
        output = ANSI.sub("", output)
        fatal = [line for line in output.splitlines() if "[FATAL]" in line]
        self.assertEqual(process.returncode, 1, output)
        self.assertEqual(len(fatal), 1, output)
        self.assertIn(expected, fatal[0])
        for bad in BAD_OUTPUT:
            self.assertNotIn(bad, output)

    def test_initial_pose_off_the_map(self):
        self.parameters("tb3_7", 9.0, 2.0)
        self.assert_exits_with_one_fatal_line(
            "tb3_7", "amcl: tb3_7/amcl/initial_pose_x, initial_pose_y: (9.00, 2.00) is off the map "
                     "(x in [-0.50, 7.50], y in [-0.50, 5.50])")

    def test_initial_pose_inside_an_obstacle(self):
        self.parameters("tb3_8", 1.75, 1.5)  # the south-west column of the lab
        self.assert_exits_with_one_fatal_line(
            "tb3_8", "amcl: tb3_8/amcl/initial_pose_x, initial_pose_y: (1.75, 1.50) is inside an obstacle of the map")

    def test_initial_pose_not_a_number(self):
        self.parameters("tb3_5", float("nan"), 0.5)
        self.assert_exits_with_one_fatal_line("tb3_5", "amcl: tb3_5/amcl/initial_pose_x: expected a number, got ")

    def test_initial_pose_not_numeric(self):
        self.parameters("tb3_6", 0.5, "north")
        self.assert_exits_with_one_fatal_line("tb3_6", "amcl: tb3_6/amcl/initial_pose_y: expected a number, got ")

    def test_parameter_file_with_an_unknown_key(self):
        self.parameters("tb3_9", 0.5, 0.5, extra_file="bad_unknown_key.yaml")
        self.assert_exits_with_one_fatal_line("tb3_9", "amcl: tb3_9/amcl/laser_z_hitt: unknown parameter")

    def test_initialpose_message_inside_an_obstacle_is_ignored_with_a_warning(self):
        self.parameters("tb3_0", 0.5, 0.5)
        publisher = rospy.Publisher("/tb3_0/initialpose", PoseWithCovarianceStamped, queue_size=1)
        process = self.start("tb3_0")
        lines = deque()
        reader = threading.Thread(target=lambda: lines.extend(ANSI.sub("", line).rstrip() for line in process.stdout),
                                  daemon=True)
        reader.start()
        try:
            deadline = time.time() + 30.0
            while publisher.get_num_connections() == 0 or not self.printed(lines, "[ INFO]", "amcl: received a"):
                self.assertIsNone(process.poll(), "amcl exited early:\n" + "\n".join(lines))
                self.assertLess(time.time(), deadline, "amcl did not subscribe to initialpose and take the map:\n"
                                + "\n".join(lines))
                time.sleep(0.05)
            publisher.publish(self.pose(1.75, 1.5))
            self.wait_printed(lines, "[ WARN]",
                              "amcl: tb3_0/initialpose: (1.75, 1.50) is inside an obstacle of the map: ignored")
            publisher.publish(self.pose(1.0, 1.0))
            self.wait_printed(lines, "[ INFO]", "amcl: setting the pose to (1.000, 1.000, 0.000)")
            self.assertIsNone(process.poll(), "amcl exited after a bad initialpose")
        finally:
            process.terminate()
            process.wait(timeout=30)
            reader.join(timeout=10)
        output = "\n".join(lines)
        for bad in BAD_OUTPUT + ("[FATAL]", "[ERROR]"):
            self.assertNotIn(bad, output)
        # The bad pose was not taken: the only pose set is the good one.
        self.assertEqual(1, sum("setting the pose to" in line for line in lines), output)

    @staticmethod
    def pose(x, y):
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id = "map"
        msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
        msg.pose.pose.orientation.w = 1.0
        msg.pose.covariance[0] = msg.pose.covariance[7] = msg.pose.covariance[35] = 0.01
        return msg

    @staticmethod
    def printed(lines, level, text):
        """A line of the node's output at `level` ("[ INFO]", "[ WARN]") that holds `text`."""
        return any(line.startswith(level) and text in line for line in list(lines))

    def wait_printed(self, lines, level, text):
        deadline = time.time() + 20.0
        while not self.printed(lines, level, text):
            self.assertLess(time.time(), deadline, "amcl did not print %s %r:\n%s" % (level, text, "\n".join(lines)))
            time.sleep(0.05)


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "loc_bad_input", AmclBadInputTest)
