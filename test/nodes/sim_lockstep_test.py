#!/usr/bin/env python3
"""rostest: lock-step runs end in bit-identical poses, on an idle and on a loaded machine.

Runs ``sim.launch robots:=2 lockstep:=true rtf:=0`` three times against the test's master,
each with the scripted controller test/nodes/sim_lockstep_commander.py, which drives both
robots with tick-dependent commands up to ``~final_tick`` and writes the final ground-truth
poses. The first run answers every tick; the second and third act only on every second tick and
let the simulator run through the others (LockstepAck.next_stamp), which must not change anything.
The third run shares the machine with two busy-looping processes (one per core).

A controller that subscribes while the simulator is paused on an unanswered tick (a task
manager that stepped before every move_base had connected) still receives that tick: the
simulator re-sends it, paused or not.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

import rospy
import rostest
from std_srvs.srv import SetBool

from marl_mrta.msg import SimTick
from marl_mrta.srv import StepSim

from marl_mrta.ros.process_group import stop_process_group

START_POSES = {"tb3_0": (0.5, 0.5), "tb3_1": (0.5, 4.5)}  # config/sim.yaml


class LockstepTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="sim_lockstep_")
        self.final_tick = int(rospy.get_param("~final_tick", 400))

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def run_once(self, tag, period=0.0):
        result_path = os.path.join(self.tmp, tag + ".json")
        log = open(os.path.join(self.tmp, tag + ".log"), "w")
        simulator = subprocess.Popen(
            ["roslaunch", "marl_mrta", "sim.launch", "robots:=2", "lockstep:=true", "rtf:=0",
             "robot_description:=false"],
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        commander = subprocess.Popen(
            # Beside this file (rosrun would stop at a second copy, e.g. a workspace built inside the checkout).
            [sys.executable, os.path.join(os.path.dirname(os.path.abspath(__file__)), "sim_lockstep_commander.py"),
             "__name:=commander_" + tag,
             "_final_tick:=%d" % self.final_tick, "_result_file:=" + result_path, "_period:=%g" % period],
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            commander.wait(timeout=240)
        except subprocess.TimeoutExpired:
            self.fail("%s: the commander did not reach tick %d (log: %s)" % (tag, self.final_tick, log.name))
        finally:
            stop_process_group(commander, 20.0)
            stop_process_group(simulator, 20.0)
            log.close()
        self.assertEqual(commander.returncode, 0, "%s: commander failed, log:\n%s" % (tag, open(log.name).read()))
        with open(result_path) as f:
            result = json.load(f)
        rospy.loginfo("%s run: poses %s, %d collision events", tag, result["poses"], len(result["collisions"]))
        return result

    def test_runs_are_bit_identical_also_under_load(self):
        first = self.run_once("first")
        second = self.run_once("second", period=0.1)
        busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
        try:
            loaded = self.run_once("loaded", period=0.1)
        finally:
            for process in busy:
                process.kill()
                process.wait()

        self.assertEqual(sorted(first["poses"]), ["tb3_0", "tb3_1"])
        for name, (x0, y0) in START_POSES.items():
            x, y = float.fromhex(first["poses"][name][0]), float.fromhex(first["poses"][name][1])
            self.assertGreater(abs(x - x0) + abs(y - y0), 0.3, "%s did not move" % name)
        self.assertEqual(second["poses"], first["poses"])
        self.assertEqual(loaded["poses"], first["poses"])
        self.assertEqual(second["collisions"], first["collisions"])
        self.assertEqual(loaded["collisions"], first["collisions"])

    def test_a_paused_simulator_re_sends_an_unanswered_tick(self):
        log = open(os.path.join(self.tmp, "paused.log"), "w")
        simulator = subprocess.Popen(
            ["roslaunch", "marl_mrta", "sim.launch", "robots:=2", "lockstep:=true", "rtf:=0",
             "robot_description:=false"],
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            rospy.wait_for_service("/simulator/step", timeout=60)
            rospy.ServiceProxy("/simulator/pause", SetBool)(True)
            stepped = rospy.ServiceProxy("/simulator/step", StepSim)(3)   # sent before anyone listens
            ticks = []
            subscriber = rospy.Subscriber("/simulator/tick", SimTick, lambda msg: ticks.append(msg.tick))
            deadline = time.monotonic() + 5.0
            while stepped.tick not in ticks and time.monotonic() < deadline:
                rospy.rostime.wallsleep(0.05)
            subscriber.unregister()
        finally:
            stop_process_group(simulator, 20.0)
            log.close()
        self.assertIn(stepped.tick, ticks, "the paused simulator did not re-send tick %d" % stepped.tick)


if __name__ == "__main__":
    rospy.init_node("sim_lockstep_test")
    rostest.rosrun("marl_mrta", "sim_lockstep", LockstepTest)
