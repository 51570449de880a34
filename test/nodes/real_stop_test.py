#!/usr/bin/env python3
"""rostest: safe stops of real.launch against the stand-in (lab_2r, the exact plan).

1. A robot dies mid-episode: tb3_1's stand-in process (stand_in_processes:=per_robot, one process
   per robot as on separate machines) is SIGKILLed while both robots drive. Once its silence passes
   the configured limit, every robot is stopped within 0.5 s: each robot's last moving command on
   cmd_vel comes before that and zero commands follow. The abort reason names tb3_1 and the silent
   part, and the partial episode is the aborted episode of the evaluation's result file (and of the
   manager's own file).
2. Ctrl-C: the task manager gets SIGINT (what roslaunch's Ctrl-C sends each node) mid-episode; every
   robot is stopped within 0.5 s, and the manager writes the partial episode into the file the
   launch names. This run waits for the operator's go (~go), which the test gives.
"""
import json
import os
import sys
import tempfile
import time
import unittest
from pathlib import Path

import rospy
import rostest
from std_srvs.srv import Trigger

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from real_test_helpers import (ROBOTS, CommandWatch, interrupt_node, kill_node,  # noqa: E402
                               start_real_launch, wait_exit)

from marl_mrta.common.config import read_yaml  # noqa: E402
from marl_mrta.common.paths import default_config_path  # noqa: E402
from marl_mrta.evaluation.sim_to_real import stop_time  # noqa: E402

STOP_WITHIN = 0.5   # s: the bound, from the moment the fault is known
MANAGER = "/rl_task_allocation_manager"
LIMITS = read_yaml(default_config_path("task_manager.yaml")).data


class RealStopTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("real_test")
        cls.watch = CommandWatch()

    def assert_stopped_within(self, fault_known, what):
        time.sleep(2.0)   # the stop's hold, and any command still in flight
        for ns in ROBOTS:
            stopped = stop_time(self.watch.of(ns), fault_known - 1.0)
            self.assertIsNotNone(stopped, "%s: still commanded to move after %s" % (ns, what))
            latency = stopped - fault_known
            rospy.loginfo("%s: %s: stopped %.3f s after the fault was known", ns, what, latency)
            self.assertLessEqual(latency, STOP_WITHIN, "%s: stopped %.3f s after %s" % (ns, latency, what))

    def test_1_a_robot_that_dies_stops_every_robot(self):
        work = tempfile.mkdtemp(prefix="real_stop_kill_")
        out = os.path.join(work, "result.json")
        aborted = os.path.join(work, "aborted.json")
        launch = start_real_launch(["stand_in:=true", "stand_in_processes:=per_robot", "method:=exact", "episodes:=2",
                                    "go:=true", "nav:=builtin", "out:=" + out, "aborted_episode_file:=" + aborted],
                                   os.path.join(work, "launch.log"))
        self.assertTrue(self.watch.wait_driving(240.0), "the robots did not start driving")
        time.sleep(3.0)
        killed = kill_node("/tb3_1/turtlebot3_stand_in")
        # The fault is known once the first of the robot's parts has been silent for its limit.
        limit = min(LIMITS["odom_silent_after"], LIMITS["scan_silent_after"])
        self.assert_stopped_within(killed + limit, "tb3_1's stand-in was killed")
        code = wait_exit(launch, 120.0)
        log = Path(work, "launch.log").read_text()[-3000:]
        self.assertIsNotNone(code, "real.launch did not end after the abort:\n" + log)
        document = json.loads(Path(out).read_text())
        episodes = document["results"][0]["episodes"]
        self.assertEqual(len(episodes), 1, "no episode may start after a safety stop")
        self.assertFalse(episodes[0]["complete"])
        reason = document["results"][0]["representative_episode"]["abort_reason"]
        self.assertRegex(reason, r"^tb3_1: (odom|scan) silent for 1\.\d s$")
        manager_copy = json.loads(Path(aborted).read_text())
        self.assertEqual(manager_copy["abort_reason"], reason)
        self.assertEqual(manager_copy["episode"]["makespan"], document["results"][0]["representative_episode"]["makespan"])

    def test_2_ctrl_c_stops_every_robot_and_the_manager_writes_the_episode(self):
        work = tempfile.mkdtemp(prefix="real_stop_sigint_")
        aborted = os.path.join(work, "aborted.json")
        launch = start_real_launch(["stand_in:=true", "method:=exact", "episodes:=1", "go:=false", "nav:=builtin",
                                    "out:=" + os.path.join(work, "result.json"), "aborted_episode_file:=" + aborted],
                                   os.path.join(work, "launch.log"))
        go = rospy.ServiceProxy(MANAGER + "/go", Trigger)
        go.wait_for_service(240.0)
        deadline = time.monotonic() + 240.0
        while not go().success:   # the first reset: both robots drive to their start poses first
            self.assertLess(time.monotonic(), deadline, "the manager never waited for the go")
            time.sleep(0.5)
        self.assertTrue(self.watch.wait_driving(60.0), "the robots did not start driving after the go")
        time.sleep(3.0)
        interrupted = interrupt_node(MANAGER)
        self.assert_stopped_within(interrupted, "SIGINT to the task manager")
        wait_exit(launch, 60.0)
        self.assertTrue(os.path.isfile(aborted), Path(work, "launch.log").read_text()[-3000:])
        document = json.loads(Path(aborted).read_text())
        self.assertTrue(document["aborted"])
        self.assertEqual(document["mode"], "real")
        self.assertTrue(document["abort_reason"].startswith("node shutdown (signal-2)"), document["abort_reason"])
        self.assertFalse(document["episode"]["complete"])
        self.assertGreater(document["episode"]["makespan"], 0.0)


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "real_stop", RealStopTest)
