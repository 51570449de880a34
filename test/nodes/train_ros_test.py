#!/usr/bin/env python3
"""rostest: MAPPO training on the ros backend (two arenas of one simulator, test/rostest/train_ros.test).

- A short training through `rl_manager train --backend ros --arenas 2` writes a checkpoint and
  an actor whose counters and losses are those of the updates it ran (finite), with episodes
  from both arenas.
- A training stopped by SIGINT in its second update keeps the checkpoint of its first update;
  `--resume` continues from it: the update counter and the step count go on from there
  (1, 2, 3 …), they do not restart at 0.
- train.launch (backend:=embedded) runs the trainer node to the end of its budget.
Sizes are tiny (5 decision steps per arena per update); nothing here asserts speed.
"""
import json
import math
import os
import signal
import subprocess
import tempfile
import time
import unittest

import roslib.packages
import rosgraph
import rospy
import rostest
import torch

from marl_mrta.common.paths import package_root

SCENARIO = str(package_root() / "scenarios" / "lab_2r.xml")
# 10 decision steps per update over 2 arenas, GRU chunks of 5, one greedy episode per arena.
TINY = ["--set", "batch_size=10", "--set", "minibatch_size=10", "--set", "chunk_length=5",
        "--set", "eval_every=0", "--set", "eval_episodes=2"]


def rl_manager():
    return roslib.packages.find_node("marl_mrta", "rl_manager")[0]


def read_checkpoint(run):
    return torch.load(os.path.join(run, "checkpoint.pt"), map_location="cpu", weights_only=True)


def finite(value):
    return isinstance(value, (int, float)) and math.isfinite(value)


class TrainRosTest(unittest.TestCase):
    def train(self, run, *options, timeout=600):
        command = [rl_manager(), "train", "--backend", "ros", "--arenas", "2", "--scenario", SCENARIO,
                   "--out", run, *options]
        return subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout)

    def test_a_short_training_writes_a_checkpoint(self):
        run = os.path.join(tempfile.mkdtemp(prefix="train_ros_"), "run")
        done = self.train(run, "--seed", "3", "--set", "total_env_steps=20", *TINY)
        tail = done.stdout[-3000:]
        self.assertEqual(done.returncode, 0, tail)
        self.assertIn("2 ROS arenas", done.stdout)
        data = read_checkpoint(run)
        self.assertEqual(data["counters"]["update"], 2, tail)
        self.assertEqual(data["counters"]["env_steps"], 20)
        self.assertEqual(data["config"]["n_envs"], 2)
        updates = data["history"]["updates"]
        self.assertEqual([u["update"] for u in updates], [1, 2])
        for metrics in updates:
            for key in ("loss", "policy_loss", "value_loss", "entropy", "grad_norm"):
                self.assertTrue(finite(metrics[key]), (key, metrics[key]))
        self.assertEqual(len(data["history"]["evaluations"]), 1)   # the final greedy evaluation, in the arenas
        with open(os.path.join(run, "history.json")) as handle:
            history = json.load(handle)
        self.assertEqual(len(history["updates"]), 2)
        self.assertTrue(os.path.isfile(os.path.join(run, "actor.pt")))
        self.assertTrue(os.path.isfile(os.path.join(run, "plots", "losses.png")))
        from marl_mrta.mappo.policy import load_policy
        policy = load_policy(os.path.join(run, "actor.pt"))
        self.assertEqual(policy.action_mask, "logic")

    def test_arena_managers_leave_the_lock_step_answers_to_the_simulator(self):
        # With several arenas the clock is shared and never paused: a manager reads from /clock
        # how far the controllers have got (sim_link.SimulatorLink.tracks_answers), instead of
        # receiving every robot's answer at every tick. The simulator still takes them.
        publications, subscriptions, _ = rosgraph.Master("/train_ros_test").getSystemState()
        takers = dict(subscriptions).get("/simulator/lockstep_ack", [])
        # The simulator's process: /simulator, or its nodelet manager (tasks.launch nodelets:=true).
        simulator_host = dict(publications).get("/clock", ["/simulator"])
        self.assertEqual(len(simulator_host), 1)
        self.assertIn(simulator_host[0], takers)
        for arena in (0, 1):
            self.assertNotIn(f"/arena_{arena}/rl_task_allocation_manager", takers)

    def test_b_killed_run_resumes_from_its_checkpoint(self):
        run = os.path.join(tempfile.mkdtemp(prefix="train_ros_resume_"), "run")
        command = [rl_manager(), "train", "--backend", "ros", "--arenas", "2", "--scenario", SCENARIO, "--out", run,
                   "--seed", "4", "--set", "total_env_steps=30", *TINY]
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:
            deadline = time.monotonic() + 400
            while not os.path.isfile(os.path.join(run, "checkpoint.pt")):
                self.assertIsNone(process.poll(), "training ended before its first checkpoint")
                self.assertLess(time.monotonic(), deadline, "no checkpoint after 400 s")
                time.sleep(0.2)
            process.send_signal(signal.SIGINT)
            output, _ = process.communicate(timeout=120)
        finally:
            if process.poll() is None:
                process.kill()
        self.assertEqual(process.returncode, 0, output[-3000:])
        stopped = read_checkpoint(run)["counters"]
        self.assertGreaterEqual(stopped["update"], 1)
        self.assertLess(stopped["update"], 3, "the run was not stopped")
        self.assertEqual(stopped["env_steps"], 10 * stopped["update"])

        resumed = self.train(run, "--resume")
        tail = resumed.stdout[-3000:]
        self.assertEqual(resumed.returncode, 0, tail)
        self.assertIn(f"resuming {run} at update {stopped['update']}/3", resumed.stdout)
        data = read_checkpoint(run)
        self.assertEqual(data["counters"]["update"], 3)
        self.assertEqual(data["counters"]["env_steps"], 30)
        self.assertEqual([u["update"] for u in data["history"]["updates"]], [1, 2, 3])
        self.assertEqual([u["env_steps"] for u in data["history"]["updates"]], [10, 20, 30])

    def test_c_train_launch_embedded(self):
        run = os.path.join(tempfile.mkdtemp(prefix="train_launch_"), "run")
        done = subprocess.run(["roslaunch", "marl_mrta", "train.launch", "backend:=embedded", "out:=" + run,
                               "steps:=400", "options:=--set eval_every=1"],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600)
        tail = done.stdout[-3000:]
        data = read_checkpoint(run)
        self.assertEqual(data["counters"]["update"], 1, tail)
        self.assertEqual(data["config"]["total_env_steps"], 400)
        self.assertEqual(len(data["history"]["evaluations"]), 1)
        self.assertTrue(os.path.isfile(os.path.join(run, "actor.pt")))


if __name__ == "__main__":
    rospy.init_node("train_ros_test")
    rostest.rosrun("marl_mrta", "train_ros", TrainRosTest)
