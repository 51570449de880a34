#!/usr/bin/env python3
"""rostest: one episode by per-robot actors that decide in turn (decision_order sequential_logic).

Trains a short actor on lab_2r with the `sequential` preset (embedded backend, seeded), runs
launch/execute.launch for one episode against the running simulator, navigation and task
manager (mask finished), and checks from the robots' own topics: robot 0 is asked with nothing
claimed, robot 1 with exactly the task robot 0 chose in that step (or nothing after a None),
each step's two tasks differ, and the episode finished every task.
"""
import json
import os
import subprocess
import tempfile
import threading
import time
import unittest

import rospy
import rostest

from marl_mrta.apps.train import main as train_main
from marl_mrta.msg import RobotObservation, TaskChoice
from marl_mrta.common.paths import package_root

ROBOTS = ("tb3_0", "tb3_1")
SCENARIO = str(package_root() / "scenarios" / "lab_2r.xml")
N_TASKS = 8


class ExecSequentialTest(unittest.TestCase):
    def test_robots_decide_in_turn_with_claimed_tasks(self):
        work = tempfile.mkdtemp(prefix="exec_sequential_")
        run = os.path.join(work, "run")
        self.assertEqual(train_main(["--scenario", SCENARIO, "--preset", "sequential", "--seed", "0",
                                     "--set", "total_env_steps=2000", "--out", run],
                                    log=lambda line: rospy.loginfo(line)), 0)
        lock = threading.Lock()
        choices = {ns: {} for ns in ROBOTS}
        claimed = {ns: {} for ns in ROBOTS}

        def on_choice(ns, msg):
            with lock:
                choices[ns][(msg.episode, msg.step)] = msg.action

        def on_observation(ns, msg):
            with lock:
                claimed[ns][(msg.episode, msg.step)] = list(bytearray(msg.claimed))

        for ns in ROBOTS:
            rospy.Subscriber("/%s/task_choice" % ns, TaskChoice, lambda m, ns=ns: on_choice(ns, m), queue_size=100)
            rospy.Subscriber("/%s/task_observation" % ns, RobotObservation, lambda m, ns=ns: on_observation(ns, m),
                             queue_size=100)

        out = os.path.join(work, "execute.json")
        launch = subprocess.run(["roslaunch", "marl_mrta", "execute.launch", "tasks:=false", "mask:=finished",
                                 "policy:=" + os.path.join(run, "actor.pt"), "scenario:=" + SCENARIO,
                                 "episodes:=1", "out:=" + out],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=900)
        tail = launch.stdout[-3000:]
        self.assertIn("decision order sequential_logic", launch.stdout, tail)
        self.assertTrue(os.path.isfile(out), "rl_manager wrote no result:\n" + tail)
        with open(out) as handle:
            result = json.load(handle)
        self.assertEqual(result["summary"]["complete_pct"], 100.0, tail)
        steps = result["records"][0]["decision_steps"]
        self.assertGreater(steps, 0)

        time.sleep(0.5)
        with lock:
            for step in range(steps):
                key = (0, step)
                self.assertIn(key, choices["tb3_0"])
                self.assertIn(key, choices["tb3_1"])
                first, second = choices["tb3_0"][key], choices["tb3_1"][key]
                self.assertEqual(claimed["tb3_0"][key], [0] * N_TASKS, key)
                expected = [1 if t == first else 0 for t in range(N_TASKS)]
                self.assertEqual(claimed["tb3_1"][key], expected, key)
                if first != N_TASKS:
                    self.assertNotEqual(first, second, key)
        rospy.loginfo("exec_sequential: %d decision steps, makespan %.2f s", steps,
                      result["summary"]["makespan_mean"])


if __name__ == "__main__":
    rospy.init_node("exec_sequential_test")
    rostest.rosrun("marl_mrta", "exec_sequential", ExecSequentialTest)
