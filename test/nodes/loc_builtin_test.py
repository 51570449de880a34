#!/usr/bin/env python3
"""rostest loc_builtin: the built-in particle filter (marl_mrta/amcl, TurtleBot3's amcl_params.yaml)
in the simulator's lock-step graph with the built-in navigation on the lab map, under measured_tb3
noise (odometry drift, lidar noise and dropout, latency, pauses). move_base navigates on the
filter's map -> odom; ground truth comes from base_pose_ground_truth.

  test_1  the tour of nav_goals_test.py (its eight goals): every goal succeeds, and at each the
          latest amcl_pose and the map -> base_footprint transform are within 0.10 m / 0.10 rad of
          the ground truth of their stamps
  test_2  global_localization: the particles spread over the lab, then, while navigation drives
          through the door, the estimate is within 0.25 m / 0.25 rad of the truth within 30 s of
          simulated time, or of the truth's twin (the lab is point-symmetric about (3.5, 2.5):
          the two see the same scans). Run on a second filter (amcl_global, same parameters,
          no tf) so that navigation keeps its localisation while this one searches.
  test_3  an initialpose 0.5 m off: the next estimate is off, and after driving two goals the
          estimate is back within 0.10 m / 0.10 rad

The filters take no part in the lock-step protocol themselves; move_base waits (tf) for the map ->
odom of every tick it controls at, and the filter's transform, stamped scan + transform_tolerance
(0.5 s), is there as soon as the filter has taken the latest scans. Every goal starts and ends on
a whole simulated second, the service calls and the initial pose come while the simulator is
paused, so a run repeats to the bit. ``~result_file`` (optional) receives the figures as JSON.
"""
import json
import math
import os
import sys
import threading
import time
import unittest

import rospy
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from std_srvs.srv import Empty, SetBool

from marl_mrta.srv import RunSim, StepSim

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from nav_goals_test import ALIGN_TICKS, Robot, angle_diff, rosrun_marking_skips, tour_goals, yaw_of  # noqa: E402

TRACK_XY, TRACK_YAW = 0.10, 0.10      # [m], [rad] at every goal of the tour, and after recovery
GLOBAL_XY, GLOBAL_YAW = 0.25, 0.25    # [m], [rad] after global localisation
GLOBAL_WITHIN = 30.0                  # [s] of simulated time
OFFSET = (0.35, 0.35)                 # [m] the wrong initial pose: 0.49 m off
WALL_TIMEOUT = 60.0                   # [s] of wall time for anything to arrive
CATCH_UP = 0.5                        # [s] of wall time for the filters to take the scans already sent
PHYSICS_RATE = 20.0                   # [Hz] config/sim.yaml
MAX_GOAL_TICKS = 20 * 600             # a goal runs for at most 10 min of sim time


def twin(x, y, yaw):
    """The pose that sees the same scans in the point-symmetric lab."""
    return 7.0 - x, 5.0 - y, angle_diff(yaw + math.pi, 0.0)


def errors(estimate, truth):
    return math.hypot(estimate[0] - truth[0], estimate[1] - truth[1]), abs(angle_diff(estimate[2], truth[2]))


class PoseLog:
    """The estimates of one filter, [(stamp, x, y, yaw)], and optionally its particle clouds."""

    def __init__(self, ns, clouds=False):
        self.lock = threading.Lock()
        self.poses = []
        self.clouds = []
        rospy.Subscriber(ns + "/amcl_pose", PoseWithCovarianceStamped, self.on_pose, queue_size=1000)
        if clouds:
            rospy.Subscriber(ns + "/particlecloud", PoseArray, self.on_cloud, queue_size=1000)

    def on_pose(self, msg):
        p = msg.pose.pose
        with self.lock:
            self.poses.append((msg.header.stamp.to_sec(), p.position.x, p.position.y, yaw_of(p.orientation)))

    def on_cloud(self, msg):
        with self.lock:
            self.clouds.append((msg.header.stamp.to_sec(), [(q.position.x, q.position.y) for q in msg.poses]))

    def latest_until(self, stamp):
        """The last estimate stamped at or before `stamp` (asked with the simulator paused after it)."""
        with self.lock:
            before = [p for p in self.poses if p[0] <= stamp]
        return before[-1] if before else None

    def after(self, stamp, timeout=WALL_TIMEOUT):
        """The first estimate stamped after `stamp` (waits for it)."""
        deadline = time.time() + timeout
        while time.time() < deadline:
            with self.lock:
                later = [p for p in self.poses if p[0] > stamp]
            if later:
                return later[0]
            time.sleep(0.01)
        raise AssertionError("no amcl_pose after %.2f s within %.0f s of wall time" % (stamp, timeout))


class LocBuiltinTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.robot = Robot("tb3_0")
        cls.amcl = PoseLog("tb3_0")
        cls.amcl_global = PoseLog("tb3_0/amcl_global", clouds=True)
        cls.tf_buffer = tf2_ros.Buffer(rospy.Duration(60.0))
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)
        cls.initial_pose = rospy.Publisher("tb3_0/initialpose", PoseWithCovarianceStamped, queue_size=1, latch=True)
        cls.pause = rospy.ServiceProxy("/simulator/pause", SetBool)
        cls.step = rospy.ServiceProxy("/simulator/step", StepSim)
        cls.run_until = rospy.ServiceProxy("/simulator/run_until", RunSim)
        rospy.wait_for_service("/simulator/run_until", WALL_TIMEOUT)
        cls.figures = {"tour": [], "global": {}, "offset": {}}
        if not cls.robot.client.wait_for_server(rospy.Duration(WALL_TIMEOUT)):
            raise AssertionError("tb3_0/move_base action server not available")
        cls.robot.latest()
        cls.amcl.after(-1.0)

    @classmethod
    def tearDownClass(cls):
        result_file = rospy.get_param("~result_file", "")
        if result_file:
            with open(result_file, "w") as out:
                json.dump(cls.figures, out, indent=1)

    def drive(self, goal, label, require_success=True):
        """One goal, sent with the simulator paused on a multiple of ALIGN_TICKS and move_base caught
        up with it; the simulator pauses itself again on the first such tick at or after the goal's
        end (/simulator/run_until), so that every goal starts and ends on ticks that do not depend
        on this node's timing, and the checks that follow see the filter's output up to then.
        Returns the sim time of the goal's end."""
        self.pause(True)
        start = self.step((-self.step(0).tick) % ALIGN_TICKS)
        deadline = time.time() + WALL_TIMEOUT
        while self.robot.acked_tick < start.tick and time.time() < deadline:
            time.sleep(0.001)
        self.robot.send(*goal)
        while self.robot.client.get_state() == GoalStatus.PENDING and time.time() < deadline:
            time.sleep(0.001)
        self.run_until(until_tick=start.tick + MAX_GOAL_TICKS, until_goals_end_of=["tb3_0"], align_ticks=ALIGN_TICKS)
        state, text, t1 = self.robot.wait()
        end_tick = int(math.ceil(round(t1 * PHYSICS_RATE) / ALIGN_TICKS)) * ALIGN_TICKS
        while self.step(0).tick < end_tick and time.time() < deadline:
            time.sleep(0.01)
        time.sleep(CATCH_UP)
        if require_success:
            self.assertEqual(GoalStatus.SUCCEEDED, state, "goal %s %s ended in state %d: %s" % (label, goal, state, text))
        return t1

    def tf_pose(self, stamp):
        t = self.tf_buffer.lookup_transform("map", "tb3_0/base_footprint", rospy.Time.from_sec(stamp), rospy.Duration(5.0))
        return t.transform.translation.x, t.transform.translation.y, yaw_of(t.transform.rotation)

    def test_1_tour_goals_tracked_within_tolerance(self):
        for label, goal in tour_goals():
            t1 = self.drive(goal, label)
            estimate = self.amcl.latest_until(t1)
            self.assertIsNotNone(estimate)
            pose_xy, pose_yaw = errors(estimate[1:], self.robot.truth_at(estimate[0])[1:4])
            tf_xy, tf_yaw = errors(self.tf_pose(t1), self.robot.truth_at(t1)[1:4])
            self.figures["tour"].append({"goal": label, "end": t1, "amcl_pose_stamp": estimate[0],
                                         "amcl_pose_error": [pose_xy, pose_yaw], "tf_error": [tf_xy, tf_yaw]})
            self.assertLessEqual(pose_xy, TRACK_XY, "goal %s: amcl_pose %.3f m off" % (label, pose_xy))
            self.assertLessEqual(pose_yaw, TRACK_YAW, "goal %s: amcl_pose %.3f rad off" % (label, pose_yaw))
            self.assertLessEqual(tf_xy, TRACK_XY, "goal %s: map -> base_footprint %.3f m off" % (label, tf_xy))
            self.assertLessEqual(tf_yaw, TRACK_YAW, "goal %s: map -> base_footprint %.3f rad off" % (label, tf_yaw))

    def test_2_global_localization_converges(self):
        goals = dict(tour_goals())
        self.drive(goals["A4"], "A4")  # west of the door; the simulator stays paused there
        start = self.robot.latest()[0]
        rospy.ServiceProxy("tb3_0/amcl_global/global_localization", Empty)()
        # Navigation drives east through the door and up the east room meanwhile.
        self.drive(goals["B1"], "B1")
        if self.robot.latest()[0] < start + GLOBAL_WITHIN:
            self.drive(goals["B3"], "B3")
        # The first cloud after the call (its next scan): the filter's maximum, over the whole lab.
        with self.amcl_global.lock:
            spread = [c for c in self.amcl_global.clouds if c[0] > start][0][1]
        xs, ys = [p[0] for p in spread], [p[1] for p in spread]
        self.assertEqual(rospy.get_param("tb3_0/amcl_global/max_particles"), len(spread))
        self.assertGreater(max(xs) - min(xs), 6.0)
        self.assertGreater(max(ys) - min(ys), 4.0)
        self.assertGreaterEqual(self.robot.latest()[0], start + GLOBAL_WITHIN, "the drive ended early")
        estimate = self.amcl_global.latest_until(start + GLOBAL_WITHIN)
        truth = self.robot.truth_at(estimate[0])[1:4]
        at_truth, at_twin = errors(estimate[1:], truth), errors(estimate[1:], twin(*truth))
        settled = None  # the first estimate from which on all are within the bound (truth or twin)
        with self.amcl_global.lock:
            after_call = [p for p in self.amcl_global.poses if start < p[0] <= start + GLOBAL_WITHIN]
        for p in after_call:
            near = min(errors(p[1:], t) for t in (self.robot.truth_at(p[0])[1:4], twin(*self.robot.truth_at(p[0])[1:4])))
            if near[0] <= GLOBAL_XY and near[1] <= GLOBAL_YAW:
                settled = settled if settled is not None else p[0] - start
            else:
                settled = None
        self.figures["global"] = {"called": start, "particles": len(spread), "estimate": estimate,
                                  "error_to_truth": at_truth, "error_to_twin": at_twin, "settled_after": settled}
        ok = lambda e: e[0] <= GLOBAL_XY and e[1] <= GLOBAL_YAW  # noqa: E731
        self.assertTrue(ok(at_truth) or ok(at_twin),
                        "%.0f s after global_localization: %.3f m / %.3f rad from the truth, %.3f m / %.3f rad from its "
                        "twin" % (GLOBAL_WITHIN, at_truth[0], at_truth[1], at_twin[0], at_twin[1]))

    def test_3_initial_pose_half_a_metre_off_recovers(self):
        self.pause(True)  # where the last goal left the robot
        stamp, x, y, yaw = self.robot.latest()[:4]
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id = "map"
        msg.header.stamp = rospy.Time.from_sec(stamp)
        msg.pose.pose.position.x, msg.pose.pose.position.y = x + OFFSET[0], y + OFFSET[1]
        msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw / 2.0), math.cos(yaw / 2.0)
        msg.pose.covariance[0] = msg.pose.covariance[7] = 0.25  # amcl's default initial spread
        msg.pose.covariance[35] = (math.pi / 12.0) ** 2
        self.initial_pose.publish(msg)
        time.sleep(1.0)  # wall: the filter takes it before the simulator goes on (still paused)
        goals = dict(tour_goals())
        end = stamp
        for label in ("B4", "B2"):
            end = self.drive(goals[label], label, require_success=False)
        first = self.amcl.after(stamp)  # the first scan after the new pose
        first_error = errors(first[1:], self.robot.truth_at(first[0])[1:4])
        self.assertGreater(first_error[0], 0.15, "the initial pose was not taken: first estimate %.3f m off" % first_error[0])
        estimate = self.amcl.latest_until(end)
        last_error = errors(estimate[1:], self.robot.truth_at(estimate[0])[1:4])
        tf_error = errors(self.tf_pose(end), self.robot.truth_at(end)[1:4])
        self.figures["offset"] = {"set_at": stamp, "first_error": first_error, "last_error": last_error,
                                  "tf_error": tf_error, "driven_until": end}
        self.assertLessEqual(last_error[0], TRACK_XY, "after the drive: %.3f m off" % last_error[0])
        self.assertLessEqual(last_error[1], TRACK_YAW, "after the drive: %.3f rad off" % last_error[1])
        self.assertLessEqual(tf_error[0], TRACK_XY)
        self.assertLessEqual(tf_error[1], TRACK_YAW)


if __name__ == "__main__":
    rospy.init_node("loc_builtin_test")
    rosrun_marking_skips("loc_builtin", LocBuiltinTest, sys.argv)
