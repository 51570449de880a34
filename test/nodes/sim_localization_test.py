#!/usr/bin/env python3
"""rostest: the simulator's publish_localization gives the same map -> odom as fake_localization,
bit for bit and stamp for stamp, and map -> odom -> base_footprint is the ground truth."""
import math
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage

NS = "tb3_0"
ODOM = NS + "/odom"
BASE = NS + "/base_footprint"
DRIVE_SIM = 16.0   # [s] of simulated driving
DRIVE_WALL_LIMIT = 60.0   # [s] of wall time at most, however slow the machine


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y ** 2 + q.z ** 2))


def planar(transform):
    return transform.translation.x, transform.translation.y, yaw_of(transform.rotation)


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]


class SimLocalizationTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sim_localization_test")
        rospy.wait_for_message("/clock", Clock, timeout=60)
        cls.lock = threading.Lock()
        cls.simulator, cls.node, cls.odom, cls.truth = {}, {}, {}, {}
        cls.orders = []  # per /tf message of the simulator: map -> odom before odom -> base_footprint
        rospy.Subscriber("/tf", TFMessage, cls.on_tf, queue_size=None)
        rospy.Subscriber("/tf_from_fake_localization", TFMessage, cls.on_node_tf, queue_size=None)
        rospy.Subscriber("/%s/base_pose_ground_truth" % NS, Odometry, cls.on_truth, queue_size=None)
        commands = rospy.Publisher("/%s/cmd_vel" % NS, Twist, queue_size=10)
        # Drive only once the simulator listens and fake_localization publishes: on a loaded
        # machine either can come up seconds after the clock, and the comparison needs both.
        deadline = time.monotonic() + DRIVE_WALL_LIMIT
        while time.monotonic() < deadline and not (commands.get_num_connections() > 0 and cls.node):
            rospy.rostime.wallsleep(0.05)
        command = Twist()
        command.linear.x, command.angular.z = 0.15, 0.4
        # Simulated, not wall, time: how far the robot drives must not depend on the machine's load.
        end = rospy.get_time() + DRIVE_SIM
        while rospy.get_time() < end and time.monotonic() < deadline:
            commands.publish(command)
            rospy.rostime.wallsleep(0.05)
        commands.publish(Twist())
        rospy.rostime.wallsleep(1.0)

    @classmethod
    def on_tf(cls, msg):
        with cls.lock:
            frames = [(t.header.frame_id, t.child_frame_id) for t in msg.transforms]
            if ("map", ODOM) in frames and (ODOM, BASE) in frames:
                cls.orders.append(frames.index(("map", ODOM)) < frames.index((ODOM, BASE)))
            for t in msg.transforms:
                key = t.header.stamp.to_nsec()
                if (t.header.frame_id, t.child_frame_id) == ("map", ODOM):
                    cls.simulator[key] = t.transform
                elif (t.header.frame_id, t.child_frame_id) == (ODOM, BASE):
                    cls.odom[key] = t.transform

    @classmethod
    def on_node_tf(cls, msg):
        with cls.lock:
            for t in msg.transforms:
                if (t.header.frame_id, t.child_frame_id) == ("map", ODOM):
                    cls.node[t.header.stamp.to_nsec()] = t.transform

    @classmethod
    def on_truth(cls, msg):
        p = msg.pose.pose
        with cls.lock:
            cls.truth[msg.header.stamp.to_nsec()] = (p.position.x, p.position.y, yaw_of(p.orientation))

    def test_same_bits_as_fake_localization_at_every_stamp(self):
        with self.lock:
            common = sorted(set(self.simulator) & set(self.node))
            pairs = [(self.simulator[k], self.node[k]) for k in common]
        self.assertGreater(len(pairs), 100, "too few map -> odom transforms from both: %d" % len(pairs))
        for mine, theirs in pairs:
            self.assertEqual((mine.translation.x, mine.translation.y, mine.translation.z),
                             (theirs.translation.x, theirs.translation.y, theirs.translation.z))
            self.assertEqual((mine.rotation.x, mine.rotation.y, mine.rotation.z, mine.rotation.w),
                             (theirs.rotation.x, theirs.rotation.y, theirs.rotation.z, theirs.rotation.w))
        # Odometry drifted (measured_tb3): the transform changed, so the comparison meant something.
        first, last = planar(pairs[0][0]), planar(pairs[-1][0])
        self.assertGreater(math.hypot(last[0] - first[0], last[1] - first[1]) + abs(last[2] - first[2]), 1e-3)

    def test_map_odom_precedes_odom_base_in_each_message(self):
        # A tf listener inserts a message's transforms one at a time. Stock costmap_2d and DWA look
        # up odom -> base at its latest stamp, then map -> odom at that stamp: between the two
        # inserts, map -> odom must already be there.
        with self.lock:
            orders = list(self.orders)
        self.assertGreater(len(orders), 100, "too few /tf messages with both transforms: %d" % len(orders))
        self.assertEqual([], [i for i, first in enumerate(orders) if not first],
                         "messages in which odom -> base_footprint comes before map -> odom")

    def test_map_odom_base_is_the_ground_truth(self):
        with self.lock:
            stamps = sorted(set(self.simulator) & set(self.odom) & set(self.truth))
            chains = [(compose(planar(self.simulator[k]), planar(self.odom[k])), self.truth[k]) for k in stamps]
        self.assertGreater(len(chains), 100, "too few stamps with all three: %d" % len(chains))
        path = sum(math.hypot(b[1][0] - a[1][0], b[1][1] - a[1][1]) for a, b in zip(chains, chains[1:]))
        self.assertGreater(path, 0.5, "the robot did not drive: %.3f m" % path)
        for (x, y, yaw), (tx, ty, tyaw) in chains:
            self.assertAlmostEqual(x, tx, delta=1e-9)
            self.assertAlmostEqual(y, ty, delta=1e-9)
            self.assertAlmostEqual(math.remainder(yaw - tyaw, 2 * math.pi), 0.0, delta=1e-9)


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "sim_localization", SimLocalizationTest)
