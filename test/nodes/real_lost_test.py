#!/usr/bin/env python3
"""rostest real_lost: a robot whose localisation is confidently wrong stops the fleet (real.launch
against the stand-in, lab_2r, the exact plan, nav:=auto: stock move_base and amcl where they are
installed, else the built-in nodes).

While both robots drive, the test gives tb3_0's amcl a wrong initial pose: 1 m from where it
is, on a free cell, with a spread of 2 cm, as an operator's slip in rviz would, or a robot lifted
and set down elsewhere. amcl stays confident there. Asserted:
- before the fault, every scan of both robots fitted the map (`scan_fit` at least scan_fit_min);
- after it, tb3_0's scan_fit falls below scan_fit_min;
- every robot's cmd_vel is zero for good within the scans of scan_fit_lost_scans (5 a second) +
  1.5 s of the wrong pose (amcl's first update, scans skipped while turning, the stop);
- the episode ends unfinished with a reason naming tb3_0 and its lost localisation, and no
  episode follows.
"""
import json
import os
import sys
import time
import unittest
from pathlib import Path

import rospy
import rostest
from geometry_msgs.msg import PoseWithCovarianceStamped
from std_msgs.msg import Float32

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from real_test_helpers import ROBOTS, CommandWatch, Recorder, start_in_work_dir, wait_exit  # noqa: E402

from marl_mrta.common.config import read_yaml  # noqa: E402
from marl_mrta.common.paths import default_config_path, package_root  # noqa: E402
from marl_mrta.evaluation.sim_to_real import displaced_position, stop_time  # noqa: E402
from marl_mrta.model.occupancy_map import load_map  # noqa: E402
from marl_mrta.ros.process_group import stop_process_group  # noqa: E402

LIMITS = read_yaml(default_config_path("task_manager.yaml")).data
STOP_AFTER = LIMITS["scan_fit_lost_scans"] / 5.0 + 1.5   # the LDS-01 turns at 5 Hz
SHIFT = 1.0   # m


class RealLostTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("real_test")
        cls.watch = CommandWatch()
        cls.fits = {ns: Recorder("/%s/scan_fit" % ns, Float32, lambda msg: (msg.data,)) for ns in ROBOTS}

    def fits_of(self, ns, since=float("-inf"), until=float("inf")):
        return [fit for t, fit in self.fits[ns].after(since) if t <= until]

    def test_a_robot_that_is_confidently_lost_stops_every_robot(self):
        launch, out, _ = start_in_work_dir("real_lost_", ["stand_in:=true", "nav:=auto", "method:=exact", "episodes:=2",
                                                         "go:=true"])
        try:
            self.assertTrue(self.watch.wait_driving(240.0), "the robots did not start driving")
            time.sleep(10.0)   # scans of a healthy drive first
            estimate = rospy.wait_for_message("/tb3_0/amcl_pose", PoseWithCovarianceStamped, timeout=10.0)
            p = estimate.pose.pose.position
            wrong = PoseWithCovarianceStamped()
            wrong.header.frame_id = "map"
            wrong.header.stamp = rospy.Time.now()
            wrong.pose.pose.position.x, wrong.pose.pose.position.y = displaced_position(
                load_map(package_root() / "maps" / "lab.yaml"), p.x, p.y, SHIFT)
            wrong.pose.pose.orientation = estimate.pose.pose.orientation
            covariance = [0.0] * 36
            covariance[0] = covariance[7] = covariance[35] = 0.02 ** 2
            wrong.pose.covariance = covariance
            publisher = rospy.Publisher("/tb3_0/initialpose", PoseWithCovarianceStamped, queue_size=1)
            deadline = time.monotonic() + 5.0
            while publisher.get_num_connections() == 0 and time.monotonic() < deadline:
                time.sleep(0.05)
            publisher.publish(wrong)
            lost = time.monotonic()
            rospy.loginfo("tb3_0 told it stands at (%.2f, %.2f), estimated at (%.2f, %.2f)",
                          wrong.pose.pose.position.x, wrong.pose.pose.position.y, p.x, p.y)
            time.sleep(STOP_AFTER + 2.0)
            for ns in ROBOTS:
                healthy = self.fits_of(ns, until=lost)
                self.assertGreater(len(healthy), 10, "%s: no scan_fit before the fault" % ns)
                rospy.loginfo("%s: scan_fit before the fault: %d scans, lowest %.3f", ns, len(healthy), min(healthy))
                self.assertGreaterEqual(min(healthy), LIMITS["scan_fit_min"])
            after = self.fits_of("tb3_0", since=lost)
            self.assertTrue(after and min(after) < LIMITS["scan_fit_min"], "tb3_0's scan_fit after the wrong pose: %s"
                            % after)
            for ns in ROBOTS:
                stopped = stop_time(self.watch.of(ns), lost)
                self.assertIsNotNone(stopped, "%s still commanded to move after tb3_0 was lost" % ns)
                rospy.loginfo("%s: cmd_vel zero for good %.3f s after the wrong pose", ns, stopped - lost)
                self.assertLessEqual(stopped - lost, STOP_AFTER)
            self.assertIsNotNone(wait_exit(launch, 120.0), "real.launch did not end after the stop")
            document = json.loads(Path(out).read_text())
            episodes = document["results"][0]["episodes"]
            self.assertEqual(1, len(episodes), "no episode may start after a safety stop")
            self.assertFalse(episodes[0]["complete"])
            reason = document["results"][0]["representative_episode"]["abort_reason"]
            self.assertRegex(reason, r"^tb3_0: localisation lost: its last 10 scans fit the map at the estimated pose "
                                     r"below 50 % \(\d\.\d s, the latest \d+ %\)$")
        finally:
            stop_process_group(launch)


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "real_lost", RealLostTest)
