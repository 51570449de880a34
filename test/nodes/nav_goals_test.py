#!/usr/bin/env python3
"""Black-box rostests of per-robot navigation (move_base action) in the simulator.

One script, several cases chosen by ``~case``:
  tour       one robot visits the eight task goals of scenarios/lab_2r.xml in order; each
             succeeds within 0.05 m / 0.17 rad of the goal, no collision event; on the way to
             the first, DWA's trajectory_cloud and cost_cloud carry dwa_local_planner's fields
  swap       two robots swap sides of the partition wall through its door at the same time;
             both succeed, no robot-robot collision
  goal_errors  a goal inside a column aborts with a clear message within the planner patience;
             invalid quaternion and unknown frame are rejected; move_base keeps working
  cancel     cancelling a goal stops the robot
  tb3_world  one robot navigates between three goals on TurtleBot3's own map (turtlebot3_world)
  repeat     two arenas, one robot each at the same start: the first goals of the tour, sent to
             both at the same tick, give the same result times and the same poses to the last bit
             (lock-step runs do not depend on message timing or machine load)
  nodelets   repeat, with the simulator and both move_base loaded as nodelets into /sim_manager
             (sim.launch nodelets:=true), which must serve their topics itself; nothing is
             logged as an error
Times are simulation time; waiting is bounded by wall-clock deadlines (a stalled lock-step
graph fails the test instead of hanging it). Goals of the tour start with the robot at rest on a
whole simulated second (the simulator paused and stepped there, move_base caught up), so a lock-step
run does not depend on when this test got around to sending them. ``~result_file`` (optional) receives per-goal
figures as JSON (used by scripts/bench_nav).
"""
import json
import math
import os
import sys
import threading
import time
import unittest
import xml.etree.ElementTree as ElementTree

import actionlib
import rosgraph
import rospkg
import rospy
import rostest
import rosunit
import rosunit.core
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import Pose2D
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionResult, MoveBaseGoal
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log
from sensor_msgs import point_cloud2
from sensor_msgs.msg import PointCloud2
from std_srvs.srv import SetBool

from marl_mrta.msg import CollisionEvent, LockstepAck
from marl_mrta.srv import ResetSim, StepSim

PKG = "marl_mrta"
XY_TOLERANCE = 0.05
YAW_TOLERANCE = 0.17
WALL_TIMEOUT = 240.0  # [s] per goal, wall clock
# Synchronised goals start on ticks that are multiples of this (1 s at 20 Hz): the same phase of
# every periodic activity (control, planning, costmap updates, scans).
ALIGN_TICKS = 20
REPEATED_GOALS = 4  # of the tour, driven by the twin robots of the repeat case


def tour_goals():
    """The tour: the eight task goals of scenarios/lab_2r.xml in order, as (id, (x, y, yaw))."""
    scenario = os.path.join(rospkg.RosPack().get_path(PKG), "scenarios", "lab_2r.xml")
    tasks = ElementTree.parse(scenario).getroot().find("tasks")
    return [(t.get("id"), (float(t.get("x")), float(t.get("y")), float(t.get("yaw")))) for t in tasks]


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def angle_diff(a, b):
    return math.atan2(math.sin(a - b), math.cos(a - b))


class Robot:
    """One robot's move_base client and ground-truth history."""

    def __init__(self, ns):
        self.ns = ns
        self.lock = threading.Lock()
        self.truth = []  # (stamp [s], x, y, yaw, linear speed, angular speed)
        self.client = actionlib.SimpleActionClient(ns + "/move_base", MoveBaseAction)
        self.result_stamps = {}  # goal id -> stamp of its result (the tick at which it ended)
        self.acked_tick = -1  # latest lock-step answer of this robot's move_base
        rospy.Subscriber("/simulator/lockstep_ack", LockstepAck, self.on_ack, queue_size=100)
        rospy.Subscriber(ns + "/base_pose_ground_truth", Odometry, self.on_truth, queue_size=100)
        rospy.Subscriber(ns + "/move_base/result", MoveBaseActionResult, self.on_result, queue_size=10)

    def on_result(self, msg):
        with self.lock:
            self.result_stamps[msg.status.goal_id.id] = msg.header.stamp.to_sec()

    def on_ack(self, msg):
        if msg.robot == self.ns:
            with self.lock:
                self.acked_tick = max(self.acked_tick, msg.tick)

    def on_truth(self, msg):
        p = msg.pose.pose
        t = msg.twist.twist
        with self.lock:
            self.truth.append((msg.header.stamp.to_sec(), p.position.x, p.position.y, yaw_of(p.orientation),
                               math.hypot(t.linear.x, t.linear.y), abs(t.angular.z)))
            del self.truth[:-4000]

    def latest(self):
        deadline = time.time() + 30.0
        while time.time() < deadline and not rospy.is_shutdown():
            with self.lock:
                if self.truth:
                    return self.truth[-1]
            time.sleep(0.01)
        raise AssertionError(self.ns + ": no ground truth received")

    def truth_at(self, stamp):
        """The last ground truth at or before `stamp` (waits until one after it has arrived)."""
        deadline = time.time() + 10.0
        while time.time() < deadline:
            with self.lock:
                if self.truth and self.truth[-1][0] >= stamp:
                    before = [s for s in self.truth if s[0] <= stamp]
                    return before[-1] if before else self.truth[0]
            time.sleep(0.005)
        return self.latest()

    def send(self, x, y, yaw, frame="map", quaternion=None):
        goal = MoveBaseGoal()
        goal.target_pose.header.frame_id = frame
        goal.target_pose.header.stamp = rospy.Time.now()
        goal.target_pose.pose.position.x = x
        goal.target_pose.pose.position.y = y
        q = goal.target_pose.pose.orientation
        if quaternion is None:
            q.z, q.w = math.sin(yaw / 2.0), math.cos(yaw / 2.0)
        else:
            q.x, q.y, q.z, q.w = quaternion
        self.client.send_goal(goal)
        return rospy.Time.now().to_sec()

    def wait_at_rest(self):
        """Waits until the robot stands still (it stops within a second of its last goal)."""
        deadline = time.time() + 30.0
        while self.latest()[4:6] != (0.0, 0.0):
            if time.time() > deadline:
                raise AssertionError(self.ns + ": the robot does not come to rest")
            time.sleep(0.005)

    def send_synchronised(self, goal):
        """Sends a goal at a known tick and phase (see send_synchronised below)."""
        return send_synchronised([(self, goal)])

    def wait(self, timeout=WALL_TIMEOUT):
        """Waits (wall clock) for the goal to end: (state, text, sim time at the end)."""
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown():
            state = self.client.get_state()
            if state not in (GoalStatus.PENDING, GoalStatus.ACTIVE, GoalStatus.PREEMPTING, GoalStatus.RECALLING):
                goal_id = self.client.gh.comm_state_machine.action_goal.goal_id.id
                end = time.time() + 5.0
                while goal_id not in self.result_stamps and time.time() < end:
                    time.sleep(0.001)
                with self.lock:
                    result_stamp = self.result_stamps.get(goal_id, rospy.Time.now().to_sec())
                return state, self.client.get_goal_status_text(), result_stamp
            time.sleep(0.002)
        raise AssertionError("%s: goal still running after %.0f s of wall time" % (self.ns, timeout))


def send_synchronised(robot_goals):
    """Sends each (robot, goal) with the robots at rest and the simulator paused on a multiple of
    ALIGN_TICKS, every move_base caught up with that tick; returns the sim time of the start."""
    for robot, _ in robot_goals:
        robot.wait_at_rest()
    pause = rospy.ServiceProxy("/simulator/pause", SetBool)
    step = rospy.ServiceProxy("/simulator/step", StepSim)
    pause(True)
    try:
        reached = step((-step(0).tick) % ALIGN_TICKS)
        deadline = time.time() + 30.0
        while any(robot.acked_tick < reached.tick for robot, _ in robot_goals) and time.time() < deadline:
            time.sleep(0.001)
        for robot, goal in robot_goals:
            robot.send(*goal)
        # The start is the tick reached (this node's /clock may not have caught up with it yet).
        t0 = reached.stamp.to_sec()
        while any(robot.client.get_state() == GoalStatus.PENDING for robot, _ in robot_goals) and time.time() < deadline:
            time.sleep(0.001)
    finally:
        pause(False)
    return t0


class NavTest(unittest.TestCase):
    robots = ["tb3_0"]

    @classmethod
    def setUpClass(cls):
        rospy.init_node("nav_goals_test")
        cls.collisions = []
        rospy.Subscriber("/simulator/collisions", CollisionEvent,
                         lambda msg: cls.collisions.append((msg.stamp.to_sec(), msg.robot, msg.other)), queue_size=100)
        cls.fleet = {ns: Robot(ns) for ns in cls.robots}
        for robot in cls.fleet.values():
            if not robot.client.wait_for_server(rospy.Duration(60.0)):
                raise AssertionError(robot.ns + "/move_base action server not available")
            robot.latest()
        cls.results = []

    @classmethod
    def tearDownClass(cls):
        result_file = rospy.get_param("~result_file", "")
        if result_file:
            with open(result_file, "w") as out:
                json.dump({"goals": cls.results, "collisions": cls.collisions}, out, indent=1)

    def reset(self, poses):
        rospy.wait_for_service("/simulator/reset", 30.0)
        names = list(poses)
        response = rospy.ServiceProxy("/simulator/reset", ResetSim)(
            arena=-1, robots=names, poses=[Pose2D(*poses[n]) for n in names])
        self.assertTrue(response.success, response.message)
        time.sleep(0.5)  # wall: lets the robots' new odometry and ground truth reach every node
        for n in names:
            stamp = self.fleet[n].latest()[0]
            self.fleet[n].truth_at(stamp + 0.3)

    def visit(self, robot, goal, label):
        """Sends one goal, checks success within tolerance, records its figures."""
        rospy.wait_for_service("/simulator/pause", 30.0)
        start = robot.latest()
        t0 = robot.send_synchronised(goal)
        state, text, t1 = robot.wait()
        self.assertEqual(GoalStatus.SUCCEEDED, state, "%s: goal %s %s ended in state %d: %s"
                         % (robot.ns, label, goal, state, text))
        _, x, y, yaw, _, _ = robot.truth_at(t1)
        error_xy = math.hypot(x - goal[0], y - goal[1])
        error_yaw = abs(angle_diff(yaw, goal[2]))
        figures = {"robot": robot.ns, "goal": label, "x": goal[0], "y": goal[1], "yaw": goal[2], "time": t1 - t0,
                   "straight_line": math.hypot(goal[0] - start[1], goal[1] - start[2]),
                   "error_xy": error_xy, "error_yaw": error_yaw, "pose": [x, y, yaw]}
        self.results.append(figures)
        self.assertLessEqual(error_xy, XY_TOLERANCE, "%s: goal %s reached %.3f m away" % (robot.ns, label, error_xy))
        self.assertLessEqual(error_yaw, YAW_TOLERANCE, "%s: goal %s reached %.3f rad off" % (robot.ns, label, error_yaw))

    def assert_no_collisions(self, only_robots=False):
        events = [c for c in self.collisions if not only_robots or c[2] != "wall"]
        self.assertEqual([], events, "collision events (sim time, robot, other): %s" % events)


class DwaClouds:
    """The first clouds of move_base's DWAPlannerROS/trajectory_cloud and cost_cloud (TurtleBot3's
    publish_traj_pc and publish_cost_grid_pc are on); subscribed only until stop()."""

    def __init__(self, ns, keep=5):
        self.ns, self.keep = ns, keep
        self.clouds = {"trajectory_cloud": [], "cost_cloud": []}
        self.subscribers = [rospy.Subscriber("%s/move_base/DWAPlannerROS/%s" % (ns, topic), PointCloud2,
                                             lambda msg, kept=kept: len(kept) < keep and kept.append(msg), queue_size=5)
                            for topic, kept in self.clouds.items()]

    def stop(self):
        for subscriber in self.subscribers:
            subscriber.unregister()

    def check(self, test):
        dwa = rospy.get_param(self.ns + "/move_base/DWAPlannerROS")
        resolution = rospy.get_param(self.ns + "/move_base/local_costmap/resolution")
        for topic, fields in (("trajectory_cloud", ["x", "y", "z", "theta", "cost"]),
                              ("cost_cloud", ["x", "y", "z", "path_cost", "goal_cost", "occ_cost", "total_cost"])):
            test.assertTrue(self.clouds[topic], topic + ": nothing published while driving")
            cloud = self.clouds[topic][-1]
            test.assertEqual(fields, [f.name for f in cloud.fields], topic)
            test.assertEqual(self.ns + "/odom", cloud.header.frame_id, topic + ": the local costmap's frame")
            points = list(point_cloud2.read_points(cloud, field_names=fields))
            test.assertGreater(len(points), 100, topic)
            if topic == "trajectory_cloud":
                costs = {p[4] for p in points}
                test.assertGreaterEqual(min(costs), 0.0, "discarded rollouts are left out")
                test.assertGreater(len(costs), 10, "a cost per scored rollout")
            else:
                test.assertEqual(0.0, min(p[4] for p in points), "the local goal's cell")
                test.assertLess(max(p[5] for p in points), 253.0, "cells in or next to obstacles are left out")
                for p in points[::97]:
                    total = resolution * (dwa["path_distance_bias"] * p[3] + dwa["goal_distance_bias"] * p[4]) \
                        + dwa["occdist_scale"] * p[5]
                    test.assertAlmostEqual(total, p[6], delta=1e-4 * max(1.0, total))


class TourTest(NavTest):
    def test_eight_task_goals_in_order(self):
        goals = tour_goals()
        self.assertEqual(8, len(goals))
        robot = self.fleet["tb3_0"]
        clouds = DwaClouds(robot.ns)
        for index, (label, goal) in enumerate(goals):
            self.visit(robot, goal, label)
            if index == 0:
                clouds.stop()  # the clouds cost a scoring of every sample per cycle
                clouds.check(self)
        self.assert_no_collisions()


class SwapTest(NavTest):
    robots = ["tb3_0", "tb3_1"]

    def test_swap_sides_through_the_door(self):
        # Both start on the door's axis (y = 2.5), facing it, 2.5 m away on each side.
        west, east = (1.0, 2.5, 0.0), (6.0, 2.5, math.pi)
        self.reset({"tb3_0": west, "tb3_1": east})
        del self.collisions[:]
        a, b = self.fleet["tb3_0"], self.fleet["tb3_1"]
        a.send(east[0], east[1], 0.0)
        b.send(west[0], west[1], math.pi)
        for robot, goal in ((a, (east[0], east[1], 0.0)), (b, (west[0], west[1], math.pi))):
            state, text, t1 = robot.wait()
            self.assertEqual(GoalStatus.SUCCEEDED, state, "%s ended in state %d: %s" % (robot.ns, state, text))
            _, x, y, _, _, _ = robot.truth_at(t1)
            self.assertLessEqual(math.hypot(x - goal[0], y - goal[1]), XY_TOLERANCE)
        self.assert_no_collisions(only_robots=True)


class GoalErrorsTest(NavTest):
    def test_goal_inside_a_column_aborts_within_planner_patience(self):
        robot = self.fleet["tb3_0"]
        patience = rospy.get_param("/tb3_0/move_base/planner_patience")
        planner_period = 1.0 / rospy.get_param("/tb3_0/move_base/planner_frequency")
        # At a known tick: this node's /clock may lag the simulator's under load (and t0 with it).
        t0 = robot.send_synchronised((1.75, 1.5, 0.0))  # centre of the south-west column
        state, text, t1 = robot.wait()
        self.assertEqual(GoalStatus.ABORTED, state, text)
        self.assertIn("Failed to find a valid plan", text)
        self.assertIn("inside an obstacle of the static map", text)
        self.assertLessEqual(t1 - t0, patience + planner_period + 0.2,
                             "aborted %.2f s after the goal (planner_patience %.1f s)" % (t1 - t0, patience))

    def test_invalid_quaternion_and_unknown_frame_are_rejected(self):
        robot = self.fleet["tb3_0"]
        robot.send(1.2, 1.0, 0.0, quaternion=(0.0, 0.0, 0.0, 0.0))
        state, text, _ = robot.wait()
        self.assertEqual(GoalStatus.ABORTED, state)
        self.assertIn("invalid quaternion", text)
        robot.send(1.2, 1.0, 0.0, quaternion=(0.7071, 0.0, 0.0, 0.7071))  # z axis not vertical
        state, text, _ = robot.wait()
        self.assertEqual(GoalStatus.ABORTED, state)
        self.assertIn("invalid quaternion", text)
        robot.send(1.2, 1.0, 0.0, frame="no_such_frame")
        state, text, _ = robot.wait()
        self.assertEqual(GoalStatus.ABORTED, state)
        self.assertIn("cannot be transformed", text)
        # ... and move_base is still working.
        self.visit(robot, (1.2, 1.0, 0.0), "after errors")


class CancelTest(NavTest):
    def test_cancel_stops_the_robot(self):
        robot = self.fleet["tb3_0"]
        robot.send(2.8, 3.1, 0.0)
        deadline = time.time() + 60.0
        while robot.latest()[4] < 0.15:
            self.assertLess(time.time(), deadline, "the robot never got moving")
            time.sleep(0.01)
        robot.client.cancel_goal()
        state, _, t_cancel = robot.wait()
        self.assertEqual(GoalStatus.PREEMPTED, state)
        # Within 1 s of simulation time the robot stands still, and stays so for 2 s more.
        stopped = robot.truth_at(t_cancel + 1.0)
        self.assertLess(stopped[4], 0.01, "linear speed %.3f m/s 1 s after cancelling" % stopped[4])
        self.assertLess(stopped[5], 0.01, "angular speed %.3f rad/s 1 s after cancelling" % stopped[5])
        later = robot.truth_at(t_cancel + 3.0)
        self.assertLess(math.hypot(later[1] - stopped[1], later[2] - stopped[2]), 0.005)


class RepeatTest(NavTest):
    robots = ["arena_0/tb3_0", "arena_1/tb3_0"]

    def test_twin_robots_drive_identically(self):
        twins = [self.fleet[ns] for ns in self.robots]
        for label, goal in tour_goals()[:REPEATED_GOALS]:
            t0 = send_synchronised([(robot, goal) for robot in twins])
            outcomes = []
            for robot in twins:
                state, text, t1 = robot.wait()
                self.assertEqual(GoalStatus.SUCCEEDED, state, "%s: goal %s: %s" % (robot.ns, label, text))
                # The result's tick and the true pose there.
                outcomes.append((round((t1 - t0) * 20.0), robot.truth_at(t1)[1:4]))
            self.assertEqual(outcomes[0], outcomes[1], "goal %s: (ticks, pose) of the twins differ" % label)


class NodeletsTest(RepeatTest):
    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        cls.errors = []
        # The graph's errors; this node's own actionlib client may complain of stale goal status.
        rospy.Subscriber("/rosout", Log, lambda m: m.level >= Log.ERROR and m.name != rospy.get_name() and
                         cls.errors.append("%s: %s" % (m.name, m.msg)), queue_size=100)
        time.sleep(1.0)  # connected to every node before the goals of the tests

    def test_simulator_map_server_and_move_base_run_in_the_manager(self):
        publishers = dict(rosgraph.Master(rospy.get_name()).getSystemState()[0])
        self.assertEqual(publishers.get("/simulator/tick"), ["/sim_manager"])
        self.assertEqual(publishers.get("/map"), ["/sim_manager"])
        subscribers = dict(rosgraph.Master(rospy.get_name()).getSystemState()[1])
        self.assertNotIn("/map_server", subscribers.get("/clock", []), "the map_server nodelet takes /clock itself")
        for ns in self.robots:
            self.assertEqual(publishers.get("/%s/cmd_vel" % ns), ["/sim_manager"], ns)
            self.assertEqual(publishers.get("/%s/move_base/status" % ns), ["/sim_manager"], ns)

    def test_z_nothing_logged_as_an_error(self):  # after the goals of test_twin_robots_drive_identically
        time.sleep(1.0)
        self.assertEqual(self.errors, [])


class Tb3WorldTest(NavTest):
    def test_three_goals_on_turtlebot3_map(self):
        if not rospy.get_param("~map_available", True):
            self.skipTest("TurtleBot3's map.yaml not found next to the repository (../shared/external/...)")
        self.reset({"tb3_0": (-2.0, -0.5, 0.0)})
        robot = self.fleet["tb3_0"]
        for label, goal in (("G1", (0.5, 0.5, 0.0)), ("G2", (0.55, -1.6, -math.pi / 2)), ("G3", (-0.55, 1.6, math.pi))):
            self.visit(robot, goal, label)
        self.assert_no_collisions()


CASES = {"tour": TourTest, "swap": SwapTest, "goal_errors": GoalErrorsTest, "cancel": CancelTest,
         "tb3_world": Tb3WorldTest, "repeat": RepeatTest, "nodelets": NodeletsTest}

def rosrun_marking_skips(test_name, case_class, argv):
    """rostest.rosrun, with skipped tests written as <skipped message=.../> into the JUnit result
    file (rosunit's XML runner writes them as passed) and one line each on stdout."""
    if "--text" in argv:  # rostest --text: results on the screen, no file
        rostest.rosrun(PKG, test_name, case_class, argv)
        return
    path = next((a[len("--gtest_output=xml:"):] for a in argv if a.startswith("--gtest_output=xml:")), None)
    path = path or rosunit.core.xml_results_file(PKG, test_name)
    result = rosunit.create_xml_runner(PKG, test_name, path).run(unittest.TestLoader().loadTestsFromTestCase(case_class))
    if result.skipped:
        tree = ElementTree.parse(path)
        reasons = {test.id().split(".")[-1]: reason for test, reason in result.skipped}
        for case in tree.getroot().iter("testcase"):
            if case.get("name") in reasons:
                ElementTree.SubElement(case, "skipped", message=reasons[case.get("name")])
        tree.write(path, encoding="utf-8", xml_declaration=True)
        for _, reason in result.skipped:
            print("%s: skipped: %s" % (test_name, reason))
    rosunit.print_unittest_summary(result)
    rospy.signal_shutdown("test complete")
    sys.exit(0 if result.wasSuccessful() else 1)


if __name__ == "__main__":
    rospy.init_node("nav_goals_test")
    case = rospy.get_param("~case")
    rosrun_marking_skips("nav_" + case, CASES[case], sys.argv)
