#!/usr/bin/env python3
"""rostest: the exact schedule on lab_2r in the ROS simulation under the measured_tb3 noise
profile (0.19 m/s for 0.22, pauses, lidar dropout, latency). The episode completes in precedence
order, the result file names the simulator's profile, and the makespan is longer than the plan's
nominal one by more than the ideal simulation's few tenths of a second (46.7 s for 46.13 s):
a simulator that ignored the profile would fail here. Nothing here asserts speed."""
import json
import os
import tempfile
import unittest

import rospy
import rostest

from marl_mrta.evaluation.cli import main as evaluate_main
from marl_mrta.ros.env_client import RosTaskEnvClient

MANAGER = "/rl_task_allocation_manager"


class TaskNoiseTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("task_noise_test")
        RosTaskEnvClient(MANAGER, wait_wall=240.0)   # the manager is up

    def test_exact_schedule_under_real_robot_noise(self):
        out = os.path.join(tempfile.mkdtemp(), "exact_noise.json")
        code = evaluate_main(["--executor", "ros", "--method", "exact", "--episodes", "1", "--out", out, "--quiet"])
        self.assertEqual(code, 0)
        with open(out) as f:
            data = json.load(f)
        self.assertEqual(data["profile"], "measured_tb3")
        summary = data["results"][0]["summary"]
        self.assertEqual(summary["complete_pct"], 100.0)
        self.assertEqual(summary["logic_consistent_pct"], 100.0)
        nominal = data["exact"]["makespan"]
        # 0.19 instead of 0.22 m/s alone stretches the driving by 16 %.
        self.assertGreater(summary["makespan_mean"], 1.05 * nominal, summary)
        rospy.loginfo("task_noise: exact plan %.2f s nominal, %.2f s under measured_tb3",
                      nominal, summary["makespan_mean"])


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "task_noise", TaskNoiseTest)
