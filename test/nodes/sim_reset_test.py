#!/usr/bin/env python3
"""rostest: /simulator/reset (all, one arena, given poses, refused poses and seeds), pause, step and run_until.

Runs against ``sim.launch robots:=2 arenas:=2``: drives one robot of each arena away from
its start pose, then checks what each reset brings back, from the ground truth and odometry
published after it.
"""
import math
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose2D, Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from std_srvs.srv import SetBool

from marl_mrta.srv import ResetSim, RunSim, StepSim

ROBOTS = ("arena_0/tb3_0", "arena_0/tb3_1", "arena_1/tb3_0", "arena_1/tb3_1")
START = {"tb3_0": (0.5, 0.5, 0.0), "tb3_1": (0.5, 4.5, 0.0)}  # config/sim.yaml


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y ** 2 + q.z ** 2))


class Latest:
    """The latest Odometry of each topic."""

    def __init__(self, suffix):
        self.lock = threading.Lock()
        self.msgs = {}
        for ns in ROBOTS:
            rospy.Subscriber("/%s/%s" % (ns, suffix), Odometry, self.store, ns, queue_size=10)

    def store(self, msg, ns):
        with self.lock:
            self.msgs[ns] = msg

    def after(self, ns, stamp, timeout=20.0):
        """The first message of `ns` stamped after `stamp` (waits for it)."""
        deadline = rospy.Time.now() + rospy.Duration(timeout)
        while not rospy.is_shutdown() and rospy.Time.now() < deadline:
            with self.lock:
                msg = self.msgs.get(ns)
            if msg is not None and msg.header.stamp > stamp:
                return msg
            rospy.rostime.wallsleep(0.01)
        raise AssertionError("no %s message after %s" % (ns, stamp))


class ResetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.wait_for_message("/clock", Clock, timeout=60)
        cls.truth = Latest("base_pose_ground_truth")
        cls.odom = Latest("odom")
        cls.cmd = {ns: rospy.Publisher("/%s/cmd_vel" % ns, Twist, queue_size=10) for ns in ROBOTS}
        for service in ("reset", "pause", "step", "run_until"):
            rospy.wait_for_service("/simulator/" + service, timeout=30)
        cls.reset = rospy.ServiceProxy("/simulator/reset", ResetSim)
        cls.pause = rospy.ServiceProxy("/simulator/pause", SetBool)
        cls.step = rospy.ServiceProxy("/simulator/step", StepSim)
        cls.run_until = rospy.ServiceProxy("/simulator/run_until", RunSim)

    def drive(self, robots, seconds=1.5):
        command = Twist()
        command.linear.x, command.angular.z = 0.2, 0.5
        end = rospy.Time.now() + rospy.Duration(seconds)
        while rospy.Time.now() < end:
            for ns in robots:
                self.cmd[ns].publish(command)
            rospy.sleep(0.1)
        for ns in robots:
            self.cmd[ns].publish(Twist())
        rospy.sleep(0.3)

    def assert_at_start(self, ns, after):
        truth = self.truth.after(ns, after)
        x, y, yaw = START[ns.split("/")[-1]]
        self.assertEqual((truth.pose.pose.position.x, truth.pose.pose.position.y), (x, y), ns)
        self.assertAlmostEqual(yaw_of(truth.pose.pose.orientation), yaw, places=9)
        odom = self.odom.after(ns, after)
        self.assertEqual((odom.pose.pose.position.x, odom.pose.pose.position.y), (0.0, 0.0), ns)

    def distance_from_start(self, ns, after):
        truth = self.truth.after(ns, after)
        x, y, _ = START[ns.split("/")[-1]]
        return math.hypot(truth.pose.pose.position.x - x, truth.pose.pose.position.y - y)

    def test_1_reset_one_arena_then_all(self):
        self.drive(["arena_0/tb3_0", "arena_1/tb3_0"])
        moved_at = rospy.Time.now()
        self.assertGreater(self.distance_from_start("arena_0/tb3_0", moved_at), 0.1)
        self.assertGreater(self.distance_from_start("arena_1/tb3_0", moved_at), 0.1)

        response = self.reset(arena=1, robots=[], poses=[])
        self.assertTrue(response.success, response.message)
        after = rospy.Time.now()
        self.assert_at_start("arena_1/tb3_0", after)
        self.assert_at_start("arena_1/tb3_1", after)
        self.assertGreater(self.distance_from_start("arena_0/tb3_0", after), 0.1)  # other arena untouched

        response = self.reset(arena=-1, robots=[], poses=[])
        self.assertTrue(response.success, response.message)
        after = rospy.Time.now()
        for ns in ROBOTS:
            self.assert_at_start(ns, after)

    def test_2_reset_to_given_poses_and_refused_poses(self):
        response = self.reset(arena=-1, robots=["arena_0/tb3_1"], poses=[Pose2D(3.0, 2.5, 1.0)])
        self.assertTrue(response.success, response.message)
        truth = self.truth.after("arena_0/tb3_1", rospy.Time.now())
        self.assertEqual((truth.pose.pose.position.x, truth.pose.pose.position.y), (3.0, 2.5))
        self.assertAlmostEqual(yaw_of(truth.pose.pose.orientation), 1.0, places=9)

        # Inside the column at (1.75, 1.5): refused, nothing moves.
        response = self.reset(arena=-1, robots=["arena_1/tb3_0"], poses=[Pose2D(1.75, 1.5, 0.0)])
        self.assertFalse(response.success)
        self.assertIn("arena_1/tb3_0", response.message)
        self.assertIn("overlaps an obstacle", response.message)
        response = self.reset(arena=-1, robots=["tb3_9"], poses=[Pose2D(1.0, 1.0, 0.0)])
        self.assertFalse(response.success)
        self.assertIn("unknown robot 'tb3_9'", response.message)
        response = self.reset(arena=0, robots=["arena_1/tb3_0"], poses=[Pose2D(1.0, 1.0, 0.0)])
        self.assertFalse(response.success)
        response = self.reset(arena=-1, robots=[], poses=[], reseed=True, seed=-3)
        self.assertFalse(response.success)
        self.assertIn("seed must be >= 0, got -3", response.message)
        response = self.reset(arena=-1, robots=[], poses=[])  # the new start pose stays
        self.assertTrue(response.success, response.message)
        truth = self.truth.after("arena_0/tb3_1", rospy.Time.now())
        self.assertEqual(truth.pose.pose.position.x, 3.0)

    def wait_for_clock(self, stamp, timeout_wall=20.0):
        """Until this node's clock shows `stamp` (messages may queue on a busy machine)."""
        deadline = time.monotonic() + timeout_wall
        while rospy.Time.now() != stamp and time.monotonic() < deadline:
            rospy.rostime.wallsleep(0.01)
        self.assertEqual(rospy.Time.now(), stamp)

    def test_3_pause_and_step(self):
        paused = self.pause(True)
        self.assertTrue(paused.success)
        paused_tick = int(paused.message.split()[-1])  # "paused at tick N"
        rate = float(rospy.get_param("/simulator/physics_rate"))
        frozen = rospy.Time(0, 0) + rospy.Duration(0, int(round(paused_tick * 1e9 / rate)))
        self.wait_for_clock(frozen)
        rospy.rostime.wallsleep(0.5)
        self.assertEqual(rospy.Time.now(), frozen, "sim time ran while paused")
        stepped = self.step(ticks=7)
        self.assertEqual(stepped.tick, paused_tick + 7)
        self.assertEqual(stepped.stamp - frozen, rospy.Duration(0, int(round(7 * 1e9 / rate))))
        self.wait_for_clock(stepped.stamp)
        self.assertTrue(self.pause(False).success)
        rospy.rostime.wallsleep(0.5)
        self.assertGreater(rospy.Time.now(), stepped.stamp)

    def test_4_run_until_pauses_on_its_tick(self):
        self.assertTrue(self.pause(True).success)
        start = self.step(ticks=0)
        target = start.tick + 15
        taken = self.run_until(until_tick=target)
        self.assertEqual(taken.tick, start.tick)
        rate = float(rospy.get_param("/simulator/physics_rate"))
        at_target = start.stamp + rospy.Duration(0, int(round(15 * 1e9 / rate)))
        self.wait_for_clock(at_target)
        rospy.rostime.wallsleep(0.5)   # at rtf 2, ten more ticks if it ran on
        self.assertEqual(self.step(ticks=0).tick, target, "the simulator did not pause on the tick asked")
        self.assertEqual(rospy.Time.now(), at_target)
        # A tick already reached keeps it paused; /simulator/pause false resumes without a limit.
        self.assertEqual(self.run_until(until_tick=target - 5).tick, target)
        rospy.rostime.wallsleep(0.3)
        self.assertEqual(self.step(ticks=0).tick, target)
        self.assertTrue(self.pause(False).success)
        rospy.rostime.wallsleep(0.5)
        self.assertGreater(self.step(ticks=0).tick, target)


if __name__ == "__main__":
    rospy.init_node("sim_reset_test")
    rostest.rosrun("marl_mrta", "sim_reset", ResetTest)
