#!/usr/bin/env python3
"""rostest: bad input makes the simulator exit 1 with one FATAL line naming file/field and problem.

Runs the `simulator` binary against the test's master once per case, each under its own
node name with the parameters sim.launch loads (config/robot_burger.yaml, config/sim.yaml,
config/noise_profiles.yaml under noise_profiles) plus one bad setting in its private namespace.
"""
import os
import re
import subprocess
import unittest

import rospkg
import rospy
import rostest
import yaml
from roslib.packages import find_node

ANSI = re.compile(r"\x1b\[[0-9;]*m")


class BadInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.package = rospkg.RosPack().get_path("marl_mrta")
        cls.defaults = {}
        for name in ("robot_burger.yaml", "sim.yaml"):
            with open(os.path.join(cls.package, "config", name)) as f:
                cls.defaults.update(yaml.safe_load(f))
        with open(os.path.join(cls.package, "config", "noise_profiles.yaml")) as f:
            cls.defaults["noise_profiles"] = yaml.safe_load(f)
        cls.defaults["map_file"] = os.path.join(cls.package, "maps", "lab.yaml")
        cls.binary = find_node("marl_mrta", "simulator")[0]
        cls.case = 0

    def fixture(self, name):
        return os.path.join(self.package, "test", "data", "maps", name)

    def run_with(self, **overrides):
        """Runs the node with the defaults plus `overrides`; returns (exit code, FATAL lines, output, ns)."""
        BadInputTest.case += 1
        name = "sim_bad_input_%d" % self.case
        params = dict(self.defaults)
        params.update(overrides)
        rospy.set_param("/" + name, params)
        result = subprocess.run([self.binary, "__name:=" + name], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                timeout=60, universal_newlines=True)
        output = ANSI.sub("", result.stdout)
        fatal = [line for line in output.splitlines() if "[FATAL]" in line]
        return result.returncode, fatal, output, "/" + name

    def assert_one_fatal_line(self, expected_parts, **overrides):
        code, fatal, output, ns = self.run_with(**overrides)
        self.assertEqual(code, 1, output)
        self.assertEqual(len(fatal), 1, output)
        for part in expected_parts:
            self.assertIn(part.replace("<ns>", ns), fatal[0])
        for bad in ("Traceback", "terminate called", "what():", "Segmentation"):
            self.assertNotIn(bad, output)

    def test_missing_map_image(self):
        path = self.fixture("bad_missing_image.yaml")
        self.assert_one_fatal_line([path + ": image: '", "does_not_exist.pgm': cannot open"], map_file=path)

    def test_malformed_map_yaml(self):
        path = self.fixture("bad_malformed.yaml")
        self.assert_one_fatal_line([path + ": yaml: malformed YAML at line 3"], map_file=path)

    def test_negative_resolution(self):
        path = self.fixture("bad_negative_resolution.yaml")
        self.assert_one_fatal_line([path + ": resolution: must be positive, got -0.05"], map_file=path)

    def test_missing_map_file(self):
        self.assert_one_fatal_line(["/nonexistent/lab.yaml: yaml: cannot open file"], map_file="/nonexistent/lab.yaml")

    def test_unknown_parameter_value(self):
        self.assert_one_fatal_line(["<ns>/noise_profile: unknown value 'foo' (expected ideal, measured_tb3)"],
                                   noise_profile="foo")

    def test_robot_starting_inside_an_obstacle(self):
        lab = self.defaults["map_file"]
        self.assert_one_fatal_line(["<ns>/start_poses[1]: robot at (1.750, 1.500, 0.000) overlaps an obstacle of " + lab],
                                   start_poses=[[0.5, 0.5, 0.0], [1.75, 1.5, 0.0]])

    def test_misspelt_parameter(self):
        self.assert_one_fatal_line(["<ns>/robts: unknown parameter"], robts=3)

    def test_wrong_parameter_type(self):
        self.assert_one_fatal_line(["<ns>/rtf: expected a number, got 'fast'"], rtf="fast")

    def test_bad_noise_profile_value(self):
        profiles = dict(self.defaults["noise_profiles"])
        profiles["measured_tb3"] = dict(profiles["measured_tb3"], lidar_dropout=[0.04, 0.02])
        self.assert_one_fatal_line(["<ns>/noise_profiles/measured_tb3/lidar_dropout: must satisfy 0 <= min <= max <= 1, "
                                    "got [0.04, 0.02]"], noise_profiles=profiles)

    def test_misspelt_noise_profile_key(self):
        profiles = dict(self.defaults["noise_profiles"])
        profiles["measured_tb3"] = dict(profiles["measured_tb3"], pause_rat=0.1)
        self.assert_one_fatal_line(["<ns>/noise_profiles/measured_tb3/pause_rat: unknown parameter"],
                                   noise_profiles=profiles)

    def test_unknown_lockstep_robot(self):
        self.assert_one_fatal_line(["<ns>/lockstep_robots: unknown robot 'tb3_7' (robots: tb3_0, tb3_1)"],
                                   lockstep=True, lockstep_robots=["tb3_7"])

    def test_good_input_runs(self):
        """The same harness with nothing wrong: runs to stop_after and exits 0 (the check above is not vacuous)."""
        code, fatal, output, _ = self.run_with(rtf=0.0, stop_after=1.0)
        self.assertEqual(code, 0, output)
        self.assertEqual(fatal, [])


if __name__ == "__main__":
    rospy.init_node("sim_bad_input_test")
    rostest.rosrun("marl_mrta", "sim_bad_input", BadInputTest)
