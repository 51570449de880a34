#!/usr/bin/env python3
"""rostest: the shipped generalist schedules lab_4r in the ROS simulation without training.

Runs launch/execute.launch policy:=generalist (its default mask for the generalist: finished)
for one episode against the running simulator, navigation and task manager, and checks the
result file: every task finished, in precedence order, by per-robot actor nodes of the set
actor (each given the scenario file).
"""
import json
import os
import subprocess
import tempfile
import unittest

import rospy
import rostest

from marl_mrta.common.paths import package_root

SCENARIO = str(package_root() / "scenarios" / "lab_4r.xml")


class ExecGeneralistTest(unittest.TestCase):
    def test_the_generalist_finishes_lab_4r_in_order(self):
        out = os.path.join(tempfile.mkdtemp(prefix="exec_generalist_"), "execute.json")
        launch = subprocess.run(["roslaunch", "marl_mrta", "execute.launch", "tasks:=false", "policy:=generalist",
                                 "scenario:=" + SCENARIO, "episodes:=1", "out:=" + out],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=500)
        tail = launch.stdout[-3000:]
        self.assertEqual(launch.returncode, 0, tail)
        self.assertIn("policies/generalist.pt", launch.stdout, tail)
        self.assertTrue(os.path.isfile(out), "rl_manager wrote no result:\n" + tail)
        with open(out) as handle:
            summary = json.load(handle)["summary"]
        self.assertEqual(summary["method"], "decentralised", tail)
        self.assertEqual(summary["n_robots"], 4, tail)
        self.assertEqual(summary["complete_pct"], 100.0, tail)
        self.assertEqual(summary["logic_consistent_pct"], 100.0, tail)
        rospy.loginfo("exec_generalist: lab_4r makespan %.2f s", summary["makespan_mean"])


if __name__ == "__main__":
    rospy.init_node("exec_generalist_test")
    rostest.rosrun("marl_mrta", "exec_generalist", ExecGeneralistTest)
