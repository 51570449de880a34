#!/usr/bin/env python3
"""rostest real_lost: a robot whose localisation is confidently wrong stops the fleet (real.launch
against the stand-in, lab_2r, the exact plan, nav:=auto: stock move_base and amcl where they are
installed, else the built-in nodes).

While both robots drive, the test gives tb3_0's amcl a wrong initial pose: 1 m from where it
is, on a free cell, with a spread of 2 cm, as an operator's slip in rviz would, or a robot lifted
and set down elsewhere. amcl stays confident there. Asserted:
- before the fault, every scan of both robots fitted the map (`scan_fit` at least scan_fit_min);
- after it, tb3_0's scan_fit falls below scan_fit_min;
- tb3_0's first unfit scan comes within AMCL_FIRST_UPDATE of the wrong pose, and it starts a run
  of scan_fit_lost_scans judged scans in a row that are all unfit (scans taken while the robot
  turns are not judged, so the run lasts 2 s of LDS-01 or longer);
- every robot's cmd_vel is zero for good within TRIP of the last scan of that run;
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
LOST_SCANS = LIMITS["scan_fit_lost_scans"]
RUN_WAIT = 20.0   # s: the longest wait for the run of unfit scans (2 s of LDS-01 and the turns between)
AMCL_FIRST_UPDATE = 1.5   # s: amcl takes the pose, its next scan (0.2 s) is placed there and judged
TRIP = 0.5   # s: from the run's last scan to zero cmd_vel (the watch's 0.05 s period, cancel, publish)
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
            deadline = time.monotonic() + RUN_WAIT
            while (len([fit for fit in self.fits_of("tb3_0", since=lost) if fit < LIMITS["scan_fit_min"]]) < LOST_SCANS
                   and time.monotonic() < deadline):
                time.sleep(0.1)
            time.sleep(TRIP + 1.0)
            for ns in ROBOTS:
                healthy = self.fits_of(ns, until=lost)
                self.assertGreater(len(healthy), 10, "%s: no scan_fit before the fault" % ns)
                rospy.loginfo("%s: scan_fit before the fault: %d scans, lowest %.3f", ns, len(healthy), min(healthy))
                self.assertGreaterEqual(min(healthy), LIMITS["scan_fit_min"])
            after = self.fits["tb3_0"].after(lost)
            unfit = [i for i, (_, fit) in enumerate(after) if fit < LIMITS["scan_fit_min"]]
            self.assertTrue(unfit, "tb3_0's scan_fit after the wrong pose: %s" % after)
            run = after[unfit[0]:unfit[0] + LOST_SCANS]
            self.assertEqual(len(run), LOST_SCANS, "tb3_0's scan_fit after the wrong pose: %s" % after)
            self.assertTrue(all(fit < LIMITS["scan_fit_min"] for _, fit in run), run)
            rospy.loginfo("tb3_0: first unfit scan %.3f s after the wrong pose, %d in a row by %.3f s",
                          run[0][0] - lost, LOST_SCANS, run[-1][0] - lost)
            self.assertLessEqual(run[0][0] - lost, AMCL_FIRST_UPDATE)
            for ns in ROBOTS:
                stopped = stop_time(self.watch.of(ns), lost)
                self.assertIsNotNone(stopped, "%s still commanded to move after tb3_0 was lost" % ns)
                rospy.loginfo("%s: cmd_vel zero for good %.3f s after the wrong pose, %.3f s after the run's last scan",
                              ns, stopped - lost, stopped - run[-1][0])
                self.assertLessEqual(stopped - run[-1][0], TRIP)
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
