#!/usr/bin/env python3
"""rostest: the simulator's topics, rates (in sim time), frames and tf for 2 robots.

Black-box: subscribes, records a window of ``~sim_seconds`` of sim time, then checks that
scan, odom and ground truth arrive at their configured rates (every period, none missing),
that frame ids have no leading slash, and that tf2 resolves tb3_0/base_scan in tb3_0/odom
at the Burger's lidar offset, with robot_state_publisher on wall time (its transforms are all
static in simulation, so it need not take /clock).
"""
import threading
import unittest

import rosgraph
import rospy
import rostest
import tf2_ros
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan

from marl_mrta.msg import SimTick

ROBOTS = ("tb3_0", "tb3_1")
SCAN_OFFSET = (-0.032, 0.0, 0.010 + 0.172)  # base_footprint -> base_link -> base_scan (TB3 Burger)


class Recorder:
    """Header stamps (ns) and the first message of each topic."""

    def __init__(self):
        self.lock = threading.Lock()
        self.stamps = {}
        self.first = {}

    def subscribe(self, topic, msg_type, stamp_of=lambda m: m.header.stamp):
        self.stamps[topic] = []
        rospy.Subscriber(topic, msg_type, self.record, (topic, stamp_of), queue_size=1000)

    def record(self, msg, args):
        topic, stamp_of = args
        with self.lock:
            self.stamps[topic].append(stamp_of(msg).to_nsec())
            self.first.setdefault(topic, msg)


class TopicsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.window = float(rospy.get_param("~sim_seconds", 6.0))
        cls.rates = {"scan": rospy.get_param("/simulator/scan_rate"),
                     "odom": rospy.get_param("/simulator/odom_rate"),
                     "base_pose_ground_truth": rospy.get_param("/simulator/odom_rate")}
        cls.physics_rate = rospy.get_param("/simulator/physics_rate")
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)
        cls.recorder = Recorder()
        for ns in ROBOTS:
            cls.recorder.subscribe("/%s/scan" % ns, LaserScan)
            cls.recorder.subscribe("/%s/odom" % ns, Odometry)
            cls.recorder.subscribe("/%s/base_pose_ground_truth" % ns, Odometry)
        cls.recorder.subscribe("/simulator/tick", SimTick, lambda m: m.stamp)
        cls.recorder.subscribe("/clock", Clock, lambda m: m.clock)
        rospy.wait_for_message("/clock", Clock, timeout=60)
        start = rospy.get_rostime()
        rospy.sleep(rospy.Duration(cls.window + 1.0))  # sim time
        with cls.recorder.lock:
            cls.stamps = {topic: list(stamps) for topic, stamps in cls.recorder.stamps.items()}
        cls.start_ns = start.to_nsec() + int(0.5e9)  # skip what was in flight when subscribing

    def window_stamps(self, topic):
        end = self.start_ns + int(self.window * 1e9)
        return [s for s in self.stamps[topic] if self.start_ns <= s < end]

    def check_rate(self, topic, rate):
        stamps = self.window_stamps(topic)
        period_ns = round(1e9 / rate)
        self.assertGreater(len(stamps), 1, topic)
        gaps = [b - a for a, b in zip(stamps, stamps[1:])]
        self.assertTrue(all(abs(gap - period_ns) <= 1 for gap in gaps),
                        "%s: stamps not every %.3f s: gaps %s" % (topic, 1.0 / rate, sorted(set(gaps))))
        self.assertAlmostEqual(len(stamps), rate * self.window, delta=1.0, msg=topic)

    def test_sensors_arrive_at_their_rates_in_sim_time(self):
        for ns in ROBOTS:
            for name, rate in self.rates.items():
                self.check_rate("/%s/%s" % (ns, name), rate)

    def test_ticks_and_clock_advance_every_physics_step(self):
        self.check_rate("/simulator/tick", self.physics_rate)
        clock = self.window_stamps("/clock")
        self.assertGreaterEqual(clock[-1] - clock[0], (self.window - 0.5) * 1e9)

    def test_frames_have_the_robot_prefix_and_no_leading_slash(self):
        for ns in ROBOTS:
            scan = self.recorder.first["/%s/scan" % ns]
            self.assertEqual(scan.header.frame_id, ns + "/base_scan")
            self.assertEqual(len(scan.ranges), 360)
            self.assertAlmostEqual(scan.range_min, 0.12, places=6)
            self.assertAlmostEqual(scan.range_max, 3.5, places=6)
            odom = self.recorder.first["/%s/odom" % ns]
            self.assertEqual(odom.header.frame_id, ns + "/odom")
            self.assertEqual(odom.child_frame_id, ns + "/base_footprint")
            truth = self.recorder.first["/%s/base_pose_ground_truth" % ns]
            self.assertEqual(truth.header.frame_id, "map")
            # Walls are in range from every start pose of the lab: not all readings are "no return".
            self.assertGreater(sum(1 for r in scan.ranges if r > 0.0), 100)

    def test_tf_resolves_base_scan_in_odom(self):
        transform = self.tf_buffer.lookup_transform("tb3_0/odom", "tb3_0/base_scan", rospy.Time(0),
                                                    rospy.Duration(10.0))
        t = transform.transform.translation
        # The robot stands at its start pose, where odometry begins: only the mounting offset.
        self.assertAlmostEqual(t.x, SCAN_OFFSET[0], places=3)
        self.assertAlmostEqual(t.y, SCAN_OFFSET[1], places=3)
        self.assertAlmostEqual(t.z, SCAN_OFFSET[2], places=3)

    def test_robot_state_publisher_does_not_take_the_clock(self):
        # Fixed wheels: every transform of the robot description is static (/tf_static, sent once),
        # so the node reads its own ~use_sim_time (false) instead of /use_sim_time.
        _, subscriptions, _ = rosgraph.Master("/sim_topics_test").getSystemState()
        clock_readers = dict(subscriptions).get("/clock", [])
        self.assertIn(rospy.get_name(), clock_readers)   # a node on sim time does take it
        for ns in ROBOTS:
            self.assertNotIn("/%s/robot_state_publisher" % ns, clock_readers)


if __name__ == "__main__":
    rospy.init_node("sim_topics_test")
    rostest.rosrun("marl_mrta", "sim_topics", TopicsTest)
