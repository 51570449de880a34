#!/usr/bin/env python3
"""rostest: the same seed gives the same ros-backend training, whatever the machine's load.

With one arena the simulator runs in lock-step and pauses between decision steps, and every
episode is reset with its own seed, which also restarts the simulator's noise: two trainings
with one seed against the same running graph (test/rostest/train_ros_repeat.test, measured_tb3
noise) must end in the same actor, tensor for tensor, and the same history of episodes and
updates (wall-clock fields aside). The second runs beside two busy-looping processes. The
second training also starts where the first left the simulator (its noise streams and clock
ran on), which the episode seeds must make irrelevant. Nothing here asserts speed.
"""
import json
import os
import subprocess
import sys
import tempfile
import unittest

import roslib.packages
import rospy
import rostest
import torch

from marl_mrta.common.paths import package_root

SCENARIO = str(package_root() / "scenarios" / "lab_2r.xml")
# Two updates of 10 decision steps, GRU chunks of 5, and the final greedy evaluation.
TINY = ["--set", "total_env_steps=20", "--set", "batch_size=10", "--set", "minibatch_size=10",
        "--set", "chunk_length=5", "--set", "eval_every=0", "--set", "eval_episodes=1"]
WALL_CLOCK = {"collect_seconds", "train_seconds", "wall_time"}


def without_wall_clock(value):
    if isinstance(value, dict):
        return {key: without_wall_clock(item) for key, item in value.items() if key not in WALL_CLOCK}
    if isinstance(value, list):
        return [without_wall_clock(item) for item in value]
    return value


class TrainRosRepeatTest(unittest.TestCase):
    def train(self, run):
        command = [roslib.packages.find_node("marl_mrta", "rl_manager")[0], "train", "--backend", "ros",
                   "--arenas", "1", "--scenario", SCENARIO, "--out", run, "--seed", "7", *TINY]
        done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=400)
        self.assertEqual(done.returncode, 0, done.stdout[-3000:])
        with open(os.path.join(run, "history.json")) as handle:
            history = json.load(handle)
        actor = torch.load(os.path.join(run, "actor.pt"), map_location="cpu", weights_only=False)
        return history, actor

    def test_same_seed_same_training_under_load(self):
        tmp = tempfile.mkdtemp(prefix="train_ros_repeat_")
        first_history, first_actor = self.train(os.path.join(tmp, "first"))
        busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
        try:
            second_history, second_actor = self.train(os.path.join(tmp, "second"))
        finally:
            for process in busy:
                process.kill()
                process.wait()

        self.assertEqual(len(first_history["updates"]), 2)
        self.assertGreater(len(first_history["episodes"]), 0)
        self.assertEqual(without_wall_clock(second_history), without_wall_clock(first_history))
        first_state, second_state = first_actor["weights"], second_actor["weights"]
        self.assertEqual(sorted(second_state), sorted(first_state))
        for name, tensor in first_state.items():
            self.assertTrue(torch.equal(second_state[name], tensor), name)


if __name__ == "__main__":
    rospy.init_node("train_ros_repeat_test")
    rostest.rosrun("marl_mrta", "train_ros_repeat", TrainRosRepeatTest)
