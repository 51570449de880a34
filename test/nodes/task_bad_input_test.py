#!/usr/bin/env python3
"""rostest: bad input makes rl_task_allocation_manager exit 1 with one FATAL line naming the
parameter or file and the problem, no traceback. Runs the node once per case against the
test's master, each under its own name with one bad setting.
"""
import os
import re
import subprocess
import unittest

import rospkg
import rospy
import rostest
from roslib.packages import find_node

ANSI = re.compile(r"\x1b\[[0-9;]*m")


class ManagerBadInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("task_bad_input_test")
        cls.package = rospkg.RosPack().get_path("marl_mrta")
        cls.scenario = os.path.join(cls.package, "scenarios", "lab_2r.xml")
        cls.binary = find_node("marl_mrta", "rl_task_allocation_manager")[0]
        cls.case = 0

    def run_with(self, params):
        ManagerBadInputTest.case += 1
        name = "/task_manager_bad_input_%d" % self.case
        if params:
            rospy.set_param(name, params)
        result = subprocess.run([self.binary, "__name:=" + name[1:]], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, timeout=120, universal_newlines=True)
        output = ANSI.sub("", result.stdout)
        return result.returncode, [line for line in output.splitlines() if "[FATAL]" in line], output, name

    def assert_one_fatal_line(self, params, *expected):
        code, fatal, output, name = self.run_with(params)
        self.assertEqual(code, 1, output)
        self.assertEqual(len(fatal), 1, output)
        for part in expected:
            self.assertIn(part.replace("<name>", name), fatal[0])
        self.assertNotIn("Traceback", output)

    def test_missing_scenario_parameter(self):
        self.assert_one_fatal_line({}, "<name>/scenario: missing: give the scenario XML file")

    def test_scenario_file_that_does_not_exist(self):
        self.assert_one_fatal_line({"scenario": "/nonexistent/lab.xml"},
                                   "/nonexistent/lab.xml: file: cannot read (No such file or directory)")

    def test_invalid_scenario_file(self):
        bad = os.path.join(self.package, "test", "data", "scenarios", "goal_in_obstacle.xml")
        self.assert_one_fatal_line({"scenario": bad}, bad + ': <task id="A1">: goal (1.75, 1.5) is inside an obstacle')

    def test_unknown_mask(self):
        self.assert_one_fatal_line({"scenario": self.scenario, "mask": "sometimes"},
                                   "<name>/mask: 'sometimes' is not one of none, finished, logic")

    def test_misspelt_parameter(self):
        self.assert_one_fatal_line({"scenario": self.scenario, "simulator_lost_afer": 2.0},
                                   "<name>/simulator_lost_afer: unknown parameter")

    def test_wrong_type(self):
        self.assert_one_fatal_line({"scenario": self.scenario, "arena": "first"},
                                   "<name>/arena: expected an integer, got 'first'")

    def test_no_simulator(self):
        self.assert_one_fatal_line({"scenario": self.scenario, "graph_wait": 1.0},
                                   "the graph did not come up: service /simulator/reset is not available after 1 s")


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "task_bad_input", ManagerBadInputTest)
