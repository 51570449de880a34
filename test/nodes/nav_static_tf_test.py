#!/usr/bin/env python3
"""rostest: with ~static_transform (opt-in) the built-in fake_localization puts map -> odom on /tf_static, not /tf, keeps it
consistent with the ground truth, and replaces it after /simulator/reset and initialpose."""
import math
import threading
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Pose2D, PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage

from marl_mrta.srv import ResetSim

NS = "tb3_0"
ODOM = NS + "/odom"
BASE = NS + "/base_footprint"
RESET_POSE = (1.2, 1.0, 0.5)     # free in maps/lab.yaml (a task goal of scenarios/lab_2r.xml)
INITIAL_POSE = (2.0, 2.5, -1.0)  # where initialpose says the robot is
TOLERANCE = 1e-6                 # [m], [rad]


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y ** 2 + q.z ** 2))


class StaticTfTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.wait_for_message("/clock", Clock, timeout=60)
        cls.lock = threading.Lock()
        cls.dynamic_map_odom = 0
        cls.dynamic_base = 0
        cls.static_map_odom = []
        cls.truth = None
        rospy.Subscriber("/tf", TFMessage, cls.on_tf, queue_size=None)
        rospy.Subscriber("/tf_static", TFMessage, cls.on_tf_static, queue_size=None)
        rospy.Subscriber(NS + "/base_pose_ground_truth", Odometry, cls.on_truth, queue_size=10)
        cls.buffer = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.buffer)

    @classmethod
    def on_tf(cls, msg):
        with cls.lock:
            for t in msg.transforms:
                cls.dynamic_map_odom += t.child_frame_id == ODOM
                cls.dynamic_base += t.child_frame_id == BASE

    @classmethod
    def on_tf_static(cls, msg):
        with cls.lock:
            cls.static_map_odom += [t for t in msg.transforms if t.child_frame_id == ODOM]

    @classmethod
    def on_truth(cls, msg):
        with cls.lock:
            cls.truth = msg

    def wait_for(self, condition, what, timeout=30.0):
        deadline = rospy.get_rostime() + rospy.Duration(timeout)
        while not condition():
            self.assertLess(rospy.get_rostime(), deadline, "timed out waiting for " + what)
            rospy.rostime.wallsleep(0.01)

    def map_base(self):
        """map -> base_footprint at the latest ground truth's stamp, and that ground truth."""
        self.wait_for(lambda: self.truth is not None, "ground truth")
        # On a loaded machine the first ground truth can predate the listener's first transforms:
        # then a later one, whose stamp the buffer covers.
        deadline = rospy.get_rostime() + rospy.Duration(30.0)
        while True:
            with self.lock:
                truth = self.truth
            if self.buffer.can_transform("map", BASE, truth.header.stamp, rospy.Duration(1.0)):
                break
            self.assertLess(rospy.get_rostime(), deadline, "map -> base_footprint never covered a ground truth stamp")
        t = self.buffer.lookup_transform("map", BASE, truth.header.stamp).transform
        return (t.translation.x, t.translation.y, yaw_of(t.rotation)), truth.pose.pose

    def assert_pose(self, actual, expected):
        for a, e in zip(actual, expected):
            self.assertAlmostEqual(a, e, delta=TOLERANCE, msg="%s != %s" % (actual, expected))

    def latest_static(self):
        with self.lock:
            return len(self.static_map_odom), (self.static_map_odom[-1] if self.static_map_odom else None)

    def wait_for_static(self, count, pose):
        def arrived():
            n, t = self.latest_static()
            return n > count and abs(t.transform.translation.x - pose[0]) < TOLERANCE
        self.wait_for(arrived, "a new map -> odom on /tf_static")

    def test_static_map_odom(self):
        # 1. Before any reset: map -> base is the ground truth, map -> odom only on /tf_static.
        pose, truth = self.map_base()
        self.assert_pose(pose, (truth.position.x, truth.position.y, yaw_of(truth.orientation)))
        self.wait_for(lambda: self.dynamic_base > 20, "odom -> base_footprint on /tf")
        with self.lock:
            self.assertGreater(len(self.static_map_odom), 0, "no map -> odom on /tf_static")
            self.assertEqual(self.static_map_odom[-1].header.frame_id, "map")
            self.assertEqual(self.dynamic_map_odom, 0, "map -> odom published on /tf")
            statics_while_still = len(self.static_map_odom)
        # 2. A reset to another pose restarts odometry at 0: map -> odom becomes that pose.
        reset = rospy.ServiceProxy("/simulator/reset", ResetSim)
        reset.wait_for_service(30.0)
        count, _ = self.latest_static()
        answer = reset(arena=-1, robots=[NS], poses=[Pose2D(*RESET_POSE)])
        self.assertTrue(answer.success, answer.message)
        self.wait_for_static(count, RESET_POSE)
        _, static = self.latest_static()
        self.assert_pose((static.transform.translation.x, static.transform.translation.y,
                          yaw_of(static.transform.rotation)), RESET_POSE)
        self.wait_for(lambda: self.truth.header.stamp > static.header.stamp, "ground truth after the reset")
        pose, _ = self.map_base()
        self.assert_pose(pose, RESET_POSE)
        # 3. initialpose: map -> base becomes the pose given.
        count, _ = self.latest_static()
        publisher = rospy.Publisher(NS + "/initialpose", PoseWithCovarianceStamped, queue_size=1, latch=True)
        message = PoseWithCovarianceStamped()
        message.header.frame_id = "map"
        message.pose.pose.position.x, message.pose.pose.position.y = INITIAL_POSE[:2]
        message.pose.pose.orientation.z = math.sin(0.5 * INITIAL_POSE[2])
        message.pose.pose.orientation.w = math.cos(0.5 * INITIAL_POSE[2])
        publisher.publish(message)
        self.wait_for_static(count, INITIAL_POSE)
        _, static = self.latest_static()
        self.wait_for(lambda: self.truth.header.stamp > static.header.stamp, "ground truth after initialpose")
        pose, _ = self.map_base()
        self.assert_pose(pose, INITIAL_POSE)
        with self.lock:
            self.assertEqual(self.dynamic_map_odom, 0, "map -> odom published on /tf")
            # One static per change (the first, the reset, initialpose), not one per tick.
            self.assertLessEqual(len(self.static_map_odom), statics_while_still + 2)


if __name__ == "__main__":
    rospy.init_node("nav_static_tf_test")
    rostest.rosrun("marl_mrta", "nav_static_tf", StaticTfTest)
