#!/usr/bin/env python3
"""rostest: real.launch stand_in:=true on lab_2r, as on real Burgers, started as the README's "Real
robots" recipe says (its real.launch line with stand_in:=true, and its go).

1. The stand-in shows per robot what TurtleBot3's bringup starts shows (turtlebot3_core's
   odom, odom -> base_footprint, joint_states, imu, magnetic_field, battery_state and the LDS-01
   driver's scan and rpms: names, types, rates, frame ids, the driver's scan header), and nothing
   a real Burger does not show (no /clock, no ground truth, no /use_sim_time); the frames follow
   the bringup files' arguments (multi_robot_name, set_lidar_frame_id) in
   ../shared/external/turtlebot3_noetic. Then the exact plan's episode completes,
   logic-consistent, the launch ends by itself after writing its result in evaluate's format, and
   every amcl_pose is within 0.25 m / 0.35 rad of the stand-in's ground truth (its file).
2. A policy trained in seconds (embedded, sequential preset) runs decentralised, one robot_actor
   per robot, and completes two episodes logic-consistently; between them the robots drive back
   to their start poses one at a time (reset_drive one_by_one): while tb3_0 drives, tb3_1 stands.
   It runs on a short scenario of the lab's west half (two robots, four tasks, a crossed
   precedence), so that its reset and two episodes take about two minutes of wall time.
"""
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import rosgraph
import rospy
import rostest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState, Imu, JointState, LaserScan, MagneticField
from std_msgs.msg import UInt16
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from real_test_helpers import ROBOTS, readme_recipe, start_real_launch, wait_exit  # noqa: E402

from marl_mrta.apps.train import main as train_main
from marl_mrta.common.paths import package_root
from marl_mrta.evaluation.sim_to_real import localisation_errors, read_ground_truth
from marl_mrta.msg import TaskChoice
from marl_mrta.ros.sim_link import quaternion_to_yaw

SCENARIO = str(package_root() / "scenarios" / "lab_2r.xml")
SHORT_SCENARIO = str(package_root() / "test" / "data" / "scenarios" / "lab_2r4t.xml")
BRINGUP = package_root().parent / "shared" / "external" / "turtlebot3_noetic" / "turtlebot3_bringup" / "launch"
#: turtlebot3_core (OpenCR firmware, ROS 1) and hls_lfcd_lds_driver: topic -> (type, rate Hz).
EXPECTED = {"odom": (Odometry, 30.0), "joint_states": (JointState, 30.0), "imu": (Imu, 200.0),
            "magnetic_field": (MagneticField, 200.0), "battery_state": (BatteryState, 30.0),
            "scan": (LaserScan, 5.0), "rpms": (UInt16, 5.0)}
RATE_TOLERANCE = 0.15      # relative, on a shared 2-core machine
LOCALISED_XY, LOCALISED_YAW = 0.25, 0.35
EPISODE_WALL = 420.0       # s: drive to start, a lab_2r episode in real time, the launch's start and end
NEXT_EPISODE_WALL = 300.0  # s: one robot after the other back to its start pose, another episode
#: The manager's log line of a robot's drive to its start pose, with its wall-clock stamp.
RESET_LINE = re.compile(r"\[(\d+\.\d+)\]: reset: (\S+) driving to its start pose")


def bringup_frames(ns):
    """The frame ids TurtleBot3's bringup gives robot `ns` when started as the docs say
    (multi_robot_name:=ns set_lidar_frame_id:=ns/base_scan), read from its launch files."""
    if not BRINGUP.is_dir():
        return None
    robot = ElementTree.parse(BRINGUP / "turtlebot3_robot.launch").getroot()
    args = {a.get("name") for a in robot.iter("arg")}
    assert {"multi_robot_name", "set_lidar_frame_id"} <= args, args
    core = ElementTree.parse(BRINGUP / "turtlebot3_core.launch").getroot()
    prefix_param = [p for p in core.iter("param") if p.get("name") == "tf_prefix"]
    assert prefix_param and prefix_param[0].get("value") == "$(arg multi_robot_name)"
    lidar = ElementTree.parse(BRINGUP / "turtlebot3_lidar.launch").getroot()
    lds = [n for n in lidar.iter("node") if n.get("pkg") == "hls_lfcd_lds_driver"]
    assert lds and any(p.get("name") == "frame_id" and p.get("value") == "$(arg set_frame_id)" for p in lds[0].iter("param"))
    # turtlebot3_core prefixes its frames with tf_prefix; the LDS driver takes frame_id as given.
    return {"odom": ns + "/odom", "base_footprint": ns + "/base_footprint", "imu": ns + "/imu_link",
            "magnetic_field": ns + "/mag_link", "joint_states": ns + "/base_link", "scan": ns + "/base_scan"}


class Recorder:
    def __init__(self):
        self.lock = threading.Lock()
        self.messages = {(ns, topic): [] for ns in ROBOTS for topic in EXPECTED}
        self.tf = []
        self.tf_publishers = {}   # node -> {(parent, child)} it sent on /tf
        self.amcl = {ns: [] for ns in ROBOTS}
        for ns in ROBOTS:
            for topic, (kind, _) in EXPECTED.items():
                rospy.Subscriber("/%s/%s" % (ns, topic), kind, self.on_message, (ns, topic), queue_size=400)
            rospy.Subscriber("/%s/amcl_pose" % ns, PoseWithCovarianceStamped, self.on_amcl, ns, queue_size=50)
        rospy.Subscriber("/tf", TFMessage, self.on_tf, queue_size=400)

    def on_message(self, msg, key):
        with self.lock:
            self.messages[key].append((time.monotonic(), msg))

    def on_tf(self, msg):
        publisher = msg._connection_header.get("callerid", "")
        with self.lock:
            self.tf.extend((time.monotonic(), t) for t in msg.transforms)
            self.tf_publishers.setdefault(publisher, set()).update(
                (t.header.frame_id, t.child_frame_id) for t in msg.transforms)

    def on_amcl(self, msg, ns):
        p = msg.pose.pose
        with self.lock:
            self.amcl[ns].append((msg.header.stamp.to_sec(), p.position.x, p.position.y, quaternion_to_yaw(p.orientation)))


class RealStandInTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("real_test")

    def run_real(self, work, args, episodes=1, go=True):
        out = os.path.join(work, "result.json")
        launch = start_real_launch(["stand_in:=true", "go:=%s" % str(go).lower(), "episodes:=%d" % episodes, "nav:=builtin",
                                    "out:=" + out, "ground_truth_dir:=" + work, *args], os.path.join(work, "launch.log"))
        return launch, out

    def readme_first_hour(self):
        """The README's "Real robots" recipe: the bringup line (on each robot: here the stand-in,
        whose frames must be the ones that line gives), real.launch's arguments, and the go."""
        bringup, real, go = readme_recipe("Real robots: the first hour.")
        namespace = bringup[0].split("=", 1)[1]
        given = dict(word.split(":=", 1) for word in bringup if ":=" in word)
        self.assertEqual(given["multi_robot_name"], namespace)
        frames = bringup_frames(namespace)
        if frames:
            self.assertEqual(given["set_lidar_frame_id"], frames["scan"])
        self.assertEqual(real[:3], ["roslaunch", "marl_mrta", "real.launch"])
        self.assertEqual(go[:2], ["rosservice", "call"])
        return real[3:], go

    def give_go(self, go_command, launch, timeout):
        """The operator's go, as the README has it, once the manager waits for one (after the drive
        to the start poses); until then the service answers that no episode waits."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and launch.poll() is None:
            done = subprocess.run(go_command, capture_output=True, text=True, timeout=30)
            if done.returncode == 0 and "success: True" in done.stdout:
                return
            time.sleep(1.0)
        self.fail("the go was never taken: " + " ".join(go_command))

    def read_result(self, launch, out, work, episodes=1):
        code = wait_exit(launch, EPISODE_WALL + (episodes - 1) * NEXT_EPISODE_WALL)
        log = Path(work, "launch.log").read_text()[-3000:]
        self.assertIsNotNone(code, "real.launch did not end by itself:\n" + log)
        self.assertTrue(os.path.isfile(out), "no result file:\n" + log)
        return json.loads(Path(out).read_text())

    def test_1_the_stand_in_shows_what_the_bringup_shows_and_the_exact_plan_completes(self):
        work = tempfile.mkdtemp(prefix="real_standin_")
        recorder = Recorder()
        real_args, go_command = self.readme_first_hour()
        launch, out = self.run_real(work, real_args, go=False)
        deadline = time.monotonic() + 120.0
        while not all(recorder.messages[(ns, "scan")] for ns in ROBOTS):
            self.assertLess(time.monotonic(), deadline, "no scans from the stand-in")
            time.sleep(0.1)
        time.sleep(8.0)   # rates over a few seconds
        with recorder.lock:
            messages = {key: list(value) for key, value in recorder.messages.items()}
            tf = list(recorder.tf)
            stand_in_tf = set().union(*[pairs for node, pairs in recorder.tf_publishers.items() if "stand_in" in node])
        self.check_topics(messages, tf)
        # The stand-in sends turtlebot3_core's odom -> base_footprint only: map -> odom is amcl's.
        self.assertEqual(stand_in_tf, {(ns + "/odom", ns + "/base_footprint") for ns in ROBOTS})

        self.give_go(go_command, launch, EPISODE_WALL)
        document = self.read_result(launch, out, work)
        self.assertEqual(document["mode"], "real")
        self.assertEqual(document["executor"], "ros")
        episode = document["results"][0]["episodes"][0]
        self.assertTrue(episode["complete"], document["results"][0]["representative_episode"]["abort_reason"])
        self.assertTrue(episode["logic_consistent"])
        self.check_localised(recorder, work)

    def check_topics(self, messages, tf):
        master = rosgraph.Master("/real_test")
        types = dict(master.getTopicTypes())
        publishers = {topic: nodes for topic, nodes in master.getSystemState()[0]}
        self.assertNotIn("/clock", publishers, "a real robot publishes no /clock")
        self.assertFalse([t for t in publishers if t.endswith("base_pose_ground_truth")], "ground truth is on a topic")
        self.assertFalse(master.hasParam("/use_sim_time") and master.getParam("/use_sim_time"))
        for ns in ROBOTS:
            frames = bringup_frames(ns) or {"odom": ns + "/odom", "base_footprint": ns + "/base_footprint",
                                            "imu": ns + "/imu_link", "magnetic_field": ns + "/mag_link",
                                            "joint_states": ns + "/base_link", "scan": ns + "/base_scan"}
            self.assertNotIn("/" + ns + "/cmd_vel", [t for t in publishers if "turtlebot3_stand_in" in str(publishers[t])])
            for topic, (kind, rate) in EXPECTED.items():
                name = "/%s/%s" % (ns, topic)
                self.assertEqual(types.get(name), kind._type, name)
                received = messages[(ns, topic)]
                span = received[-1][0] - received[0][0]
                measured = (len(received) - 1) / span
                self.assertLess(abs(measured - rate) / rate, RATE_TOLERANCE, "%s at %.1f Hz, not %.0f" % (name, measured, rate))
                last = received[-1][1]
                if topic in frames:
                    self.assertEqual(last.header.frame_id, frames[topic], name)
            odom = messages[(ns, "odom")][-1][1]
            self.assertEqual(odom.child_frame_id, frames["base_footprint"])
            joints = messages[(ns, "joint_states")][-1][1]
            self.assertEqual(list(joints.name), ["wheel_left_joint", "wheel_right_joint"])
            scan = messages[(ns, "scan")][-1][1]
            # hls_lfcd_lds_driver's header: 360 readings over a full turn from 0, 0.12-3.5 m, 0 for no return.
            self.assertEqual(len(scan.ranges), 360)
            self.assertEqual(len(scan.intensities), 360)
            self.assertEqual(scan.angle_min, 0.0)
            self.assertAlmostEqual(scan.angle_max, 2.0 * math.pi, places=5)
            self.assertAlmostEqual(scan.angle_increment, 2.0 * math.pi / 360.0, places=6)
            self.assertAlmostEqual(scan.range_min, 0.12, places=6)
            self.assertAlmostEqual(scan.range_max, 3.5, places=6)
            self.assertTrue(all(r == 0.0 or 0.12 <= r <= 3.5 for r in scan.ranges))
            self.assertTrue(all((r == 0.0) == (i == 0.0) for r, i in zip(scan.ranges, scan.intensities)))
            odom_tf = [t for _, t in tf if t.child_frame_id == frames["base_footprint"]]
            self.assertTrue(odom_tf and odom_tf[-1].header.frame_id == frames["odom"])
        self.assertFalse([t for _, t in tf if t.header.frame_id.startswith("/") or t.child_frame_id.startswith("/")])

    def check_localised(self, recorder, work):
        tracks = read_ground_truth(Path(work).glob("*.csv"))
        for ns in ROBOTS:
            with recorder.lock:
                estimates = list(recorder.amcl[ns])
            errors = localisation_errors(estimates, tracks[ns])
            self.assertGreater(len(errors), 5, "%s: too few amcl_pose to judge" % ns)
            worst_xy = max(e[0] for e in errors)
            worst_yaw = max(e[1] for e in errors)
            rospy.loginfo("%s: %d amcl_pose, worst %.3f m / %.3f rad off the ground truth", ns, len(errors),
                          worst_xy, worst_yaw)
            self.assertLess(worst_xy, LOCALISED_XY, ns)
            self.assertLess(worst_yaw, LOCALISED_YAW, ns)

    def test_2_a_trained_policy_runs_decentralised(self):
        work = tempfile.mkdtemp(prefix="real_policy_")
        run = os.path.join(work, "train")
        self.assertEqual(train_main(["--scenario", SHORT_SCENARIO, "--preset", "sequential", "--seed", "0", "--out", run],
                                    log=rospy.loginfo), 0)
        choices = {ns: [] for ns in ROBOTS}
        for ns in ROBOTS:
            rospy.Subscriber("/%s/task_choice" % ns, TaskChoice, lambda m, ns=ns: choices[ns].append(m.action),
                             queue_size=50)
        # The sequential preset trains with mask finished (real.launch assumes the tuned preset's logic).
        launch, out = self.run_real(work, ["scenario:=" + SHORT_SCENARIO, "method:=policy", "mask:=finished",
                                           "policy:=" + os.path.join(run, "actor.pt")],
                                    episodes=2)
        document = self.read_result(launch, out, work, episodes=2)
        self.assertEqual(document["mode"], "real")
        self.assertEqual(document["execution"], "decentralised")
        self.assertEqual(len(document["records"]), 2)
        for record in document["records"]:
            self.assertTrue(record["complete"])
            self.assertTrue(record["logic_consistent"])
        self.assertTrue(all(choices[ns] for ns in ROBOTS), choices)
        self.check_reset_one_by_one(work)

    def check_reset_one_by_one(self, work):
        """The reset before episode 2: tb3_0's drive starts, then tb3_1's once tb3_0 has arrived;
        in between tb3_1 stands where episode 1 left it and tb3_0 drives."""
        starts = [(float(m.group(1)), m.group(2)) for m in RESET_LINE.finditer(Path(work, "launch.log").read_text())]
        self.assertEqual([ns for _, ns in starts], ["tb3_0", "tb3_1"] * 2, starts)   # the reset of each episode
        (t0, _), (t1, _) = starts[2], starts[3]
        tracks = read_ground_truth(Path(work).glob("*.csv"))

        def travelled(ns):
            points = [(x, y) for t, x, y, _ in tracks[ns] if t0 <= t <= t1]
            return sum(math.dist(a, b) for a, b in zip(points, points[1:]))

        self.assertGreater(travelled("tb3_0"), 0.5, "tb3_0 did not drive back first")
        self.assertLess(travelled("tb3_1"), 0.02, "tb3_1 drove while tb3_0 drove back")


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "real_standin", RealStandInTest)
