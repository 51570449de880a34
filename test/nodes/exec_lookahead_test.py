#!/usr/bin/env python3
"""rostest: the robots' own actor nodes look ahead and schedule lab_3r at the exact plan's time.

Runs launch/execute.launch policy:=generalist lookahead:=true for one episode against the running
simulator, navigation and task manager (lock-step); each robot's node, looking ahead from its own
observation and opening with the actor's rollout plan, which each node makes alike (lab_3r's
proven optimum), must take another task than its actor at least once and finish every task in
precedence order, sooner than the same nodes without lookahead and within a tolerance of the
exact plan, both driven through the same graph here too (lock-step: the same episode each time).
"""
import json
import os
import re
import subprocess
import tempfile
import unittest

import rospy
import rostest

from marl_mrta.apps.evaluate import main as evaluate_main
from marl_mrta.common.paths import package_root

SCENARIO = str(package_root() / "scenarios" / "lab_3r.xml")
TOLERANCE_S = 0.1   # two physics ticks (config/sim.yaml physics_rate: 20 Hz); a tolerance, not a measured figure
OPENING = re.compile(r"the rollout plan to open with ends at ([0-9.]+) s")


class ExecLookaheadTest(unittest.TestCase):
    def execute(self, work, lookahead):
        """One episode of the generalist's actor nodes (execute.launch) in the running graph, with
        or without lookahead: the launch's output and the result's summary (every task finished)."""
        out = os.path.join(work, "execute_%s.json" % ("lookahead" if lookahead else "alone"))
        launch = subprocess.run(["roslaunch", "marl_mrta", "execute.launch", "tasks:=false", "policy:=generalist",
                                 "lookahead:=%s" % str(lookahead).lower(), "scenario:=" + SCENARIO, "episodes:=1",
                                 "reference:=false", "out:=" + out],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=500)
        tail = launch.stdout[-3000:]
        self.assertEqual(launch.returncode, 0, tail)
        with open(out) as handle:
            summary = json.load(handle)["summary"]
        self.assertEqual(summary["complete_pct"], 100.0, tail)
        return launch.stdout, summary

    def exact_through_the_graph(self, work):
        """The exact plan's episode through the same task manager (evaluate --executor ros): its document."""
        out = os.path.join(work, "exact.json")
        self.assertEqual(evaluate_main(["--executor", "ros", "--method", "exact", "--episodes", "1", "--out", out,
                                        "--quiet"]), 0)
        with open(out) as handle:
            return json.load(handle)

    def test_robots_looking_ahead_schedule_lab_3r_as_the_exact_plan(self):
        work = tempfile.mkdtemp(prefix="exec_lookahead_")
        output, looked = self.execute(work, lookahead=True)
        tail = output[-3000:]
        self.assertEqual(looked["logic_consistent_pct"], 100.0, tail)
        self.assertIn("looking ahead over 8 orientation(s)", output, tail)
        self.assertIn("opening with the actor's rollout plan", output, tail)
        self.assertIn("instead of the actor's", output, tail)   # a node took another task than its actor
        _, alone = self.execute(work, lookahead=False)
        exact = self.exact_through_the_graph(work)
        driven = exact["results"][0]["summary"]
        self.assertEqual(driven["complete_pct"], 100.0, driven)
        self.assertTrue(exact["exact"]["proven_optimal"], exact["exact"])
        # every node made the same opening plan, at lab_3r's proven optimum (the nominal model's; logged to 0.01 s)
        openings = [float(figure) for figure in OPENING.findall(output)]
        self.assertEqual(len(openings), looked["n_robots"], tail)
        for figure in openings:
            self.assertAlmostEqual(figure, exact["exact"]["makespan"], delta=0.005 + 1e-9, msg=tail)
        # through the same graph: shorter than the nodes alone, and as the exact plan
        self.assertLess(looked["makespan_mean"], alone["makespan_mean"], (looked, alone))
        self.assertLessEqual(looked["makespan_mean"], driven["makespan_mean"] + TOLERANCE_S, (looked, driven))
        rospy.loginfo("exec_lookahead: lab_3r makespan %.2f s (the nodes alone %.2f s, the exact plan %.2f s)",
                      looked["makespan_mean"], alone["makespan_mean"], driven["makespan_mean"])


if __name__ == "__main__":
    rospy.init_node("exec_lookahead_test")
    rostest.rosrun("marl_mrta", "exec_lookahead", ExecLookaheadTest)
