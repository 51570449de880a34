#!/usr/bin/env python3
"""rostest: one episode of a trained actor executed by per-robot robot_actor nodes.

Trains an actor on lab_2r with the tuned preset (embedded backend, seeded), starts
launch/evaluate.launch method:=policy (which includes launch/execute.launch: one robot_actor per
robot) against the running simulator, navigation and task manager, and checks:
rl_manager ends cleanly, its episode is complete (every task finished) and written before the
exact reference is planned (which then fills in the ratio to the proven optimum), each robot was
sent only its own observation row and answered every decision step on its own task_choice topic;
and without actor nodes rl_manager ends with one line naming the robots. Waiting is bounded
in wall time; nothing here asserts speed.
"""
import json
import os
import re
import subprocess
import tempfile
import threading
import time
import unittest

import roslib.packages
import rospy
import rostest

from marl_mrta.apps.train import main as train_main
from marl_mrta.msg import RobotObservation, TaskChoice
from marl_mrta.common.paths import package_root

ROBOTS = ("tb3_0", "tb3_1")
SCENARIO = str(package_root() / "scenarios" / "lab_2r.xml")


class ExecDecentralisedTest(unittest.TestCase):
    def test_a_missing_actors_end_with_one_line(self):
        """Without robot_actor nodes, rl_manager stops with one line naming the silent robots."""
        rl_manager = roslib.packages.find_node("marl_mrta", "rl_manager")[0]   # the built one first
        run = subprocess.run([rl_manager, "execute", "--episodes", "1", "--no-exact",
                              "--connect-timeout", "3"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, timeout=300)
        self.assertEqual(run.returncode, 1, run.stderr)
        fatal = [line for line in run.stderr.splitlines() if "FATAL" in line]
        self.assertEqual(len(fatal), 1, run.stderr)
        self.assertIn("/tb3_0, /tb3_1: no robot_actor connected", fatal[0])
        self.assertNotIn("Traceback", run.stderr)

    def test_one_episode_by_robot_actors(self):
        work = tempfile.mkdtemp(prefix="exec_decentralised_")
        run = os.path.join(work, "run")
        self.assertEqual(train_main(["--scenario", SCENARIO, "--preset", "tuned", "--seed", "0", "--out", run],
                                    log=lambda line: rospy.loginfo(line)), 0)
        actor_file = os.path.join(run, "actor.pt")
        self.assertTrue(os.path.isfile(actor_file))

        lock = threading.Lock()
        choices = {ns: [] for ns in ROBOTS}
        observed = {ns: [] for ns in ROBOTS}
        for ns in ROBOTS:
            rospy.Subscriber("/%s/task_choice" % ns, TaskChoice,
                             lambda m, ns=ns: self._add(lock, choices[ns], (m.episode, m.step, m.action)), queue_size=100)
            rospy.Subscriber("/%s/task_observation" % ns, RobotObservation,
                             lambda m, ns=ns: self._add(lock, observed[ns], m.agent_index), queue_size=100)

        out = os.path.join(work, "execute.json")
        # evaluate.launch method:=policy delegates to execute.launch (one robot_actor per robot).
        launch = subprocess.run(["roslaunch", "marl_mrta", "evaluate.launch", "method:=policy", "tasks:=false",
                                 "policy:=" + actor_file,
                                 "scenario:=" + SCENARIO, "episodes:=1", "out:=" + out],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=900)
        tail = launch.stdout[-3000:]
        self.assertIn("decentralised", launch.stdout, tail)
        self.assertTrue(os.path.isfile(out), "rl_manager wrote no result:\n" + tail)
        with open(out) as handle:
            result = json.load(handle)
        summary = result["summary"]
        self.assertEqual(result["execution"], "decentralised")
        self.assertEqual(result["profile"], "ideal")
        self.assertEqual(summary["episodes"], 1)
        self.assertEqual(summary["complete_pct"], 100.0, tail)
        episode = result["representative_episode"]
        self.assertTrue(result["records"][0]["complete"])
        steps = result["records"][0]["decision_steps"]
        self.assertGreater(steps, 0)
        # The episodes are written first; the exact reference is planned after them (the robots
        # do not wait for its search) and then fills in the ratio.
        wrote = launch.stdout.find("episode(s) in")
        planning = launch.stdout.find("planning the exact reference")
        self.assertTrue(0 <= wrote < planning, tail)
        self.assertRegex(launch.stdout, r"rl_manager: reference: best [0-9.]+ s .*, proven optimal, .*; %s updated"
                         % re.escape(out))
        self.assertTrue(result["reference"]["proven_optimal"])
        self.assertEqual(result["exact_makespan"], result["reference"]["best_makespan"])
        self.assertGreater(result["exact_makespan"], 0.0)
        self.assertAlmostEqual(summary["ratio_to_exact"], summary["makespan_mean"] / result["exact_makespan"], places=6)

        time.sleep(0.5)   # wall time: the simulator clock is paused between steps
        with lock:
            for i, ns in enumerate(ROBOTS):
                # Each robot was sent only its own row, and answered every step of episode 0.
                self.assertTrue(observed[ns] and set(observed[ns]) == {i}, (ns, observed[ns][:5]))
                answered = sorted({(e, s) for e, s, _ in choices[ns]})
                self.assertEqual(answered, [(0, s) for s in range(steps)], ns)
        rospy.loginfo("exec_decentralised: makespan %.2f s in %d decision steps, ratio to exact %s; episode keys %s",
                      summary["makespan_mean"], steps, summary["ratio_to_exact"], sorted(episode)[:6])

    @staticmethod
    def _add(lock, values, item):
        with lock:
            values.append(item)


if __name__ == "__main__":
    rospy.init_node("exec_decentralised_test")
    rostest.rosrun("marl_mrta", "exec_decentralised", ExecDecentralisedTest)
