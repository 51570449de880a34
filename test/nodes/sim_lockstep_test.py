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
simulator re-sends it, paused or not. Paused on an answered tick, it re-sends it now and then
too, so that an observer of the answers that connected late (a task manager waiting for them)
hears every controller answer it again.
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

from marl_mrta.msg import LockstepAck, SimTick
from marl_mrta.srv import StepSim

from marl_mrta.ros.process_group import stop_process_group

START_POSES = {"tb3_0": (0.5, 0.5), "tb3_1": (0.5, 4.5)}  # config/sim.yaml


class LockstepTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="sim_lockstep_")
        self.final_tick = int(rospy.get_param("~final_tick", 400))

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def start_simulator(self, tag):
        """sim.launch with two robots in lock-step as fast as possible; its process and log file."""
        log = open(os.path.join(self.tmp, tag + ".log"), "w")
        simulator = subprocess.Popen(
            ["roslaunch", "marl_mrta", "sim.launch", "robots:=2", "lockstep:=true", "rtf:=0",
             "robot_description:=false"],
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        return simulator, log

    def run_once(self, tag, period=0.0):
        result_path = os.path.join(self.tmp, tag + ".json")
        simulator, log = self.start_simulator(tag)
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
        simulator, log = self.start_simulator("paused")
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

    def test_a_paused_simulator_re_sends_an_answered_tick_for_late_observers(self):
        simulator, log = self.start_simulator("observers")
        received = []          # (wall time, tick) of every tick the controller saw
        acks = rospy.Publisher("/simulator/lockstep_ack", LockstepAck, queue_size=10)

        def answer(msg):       # a controller of both robots that answers every tick it sees
            received.append((time.monotonic(), msg.tick))
            for robot in START_POSES:
                acks.publish(LockstepAck(robot=robot, tick=msg.tick))

        controller = rospy.Subscriber("/simulator/tick", SimTick, answer)
        try:
            rospy.wait_for_service("/simulator/step", timeout=60)
            deadline = time.monotonic() + 30.0
            while acks.get_num_connections() == 0 and time.monotonic() < deadline:
                rospy.rostime.wallsleep(0.05)
            rospy.ServiceProxy("/simulator/pause", SetBool)(True)
            stepped = rospy.ServiceProxy("/simulator/step", StepSim)(3)
            answered = time.monotonic()
            while not any(tick == stepped.tick for _, tick in received) and time.monotonic() < answered + 10.0:
                rospy.rostime.wallsleep(0.05)
            answered = time.monotonic()
            heard = []         # an observer that subscribes after the answers went out
            observer = rospy.Subscriber("/simulator/lockstep_ack", LockstepAck,
                                        lambda msg: heard.append((msg.robot, msg.tick)))
            while time.monotonic() < answered + 3.5:
                rospy.rostime.wallsleep(0.05)
            observer.unregister()
        finally:
            controller.unregister()
            stop_process_group(simulator, 20.0)
            log.close()
        repeats = [t for t, tick in received if tick == stepped.tick and t > answered]
        self.assertGreaterEqual(len(repeats), 2, "answered tick %d re-sent %d times in 3.5 s while paused"
                                % (stepped.tick, len(repeats)))
        self.assertEqual({robot for robot, tick in heard if tick == stepped.tick}, set(START_POSES),
                         "a late observer did not hear every robot answer tick %d" % stepped.tick)
        self.assertTrue(all(tick == stepped.tick for _, tick in received if _ > answered),
                        "a paused simulator sent a tick other than its current one")


if __name__ == "__main__":
    rospy.init_node("sim_lockstep_test")
    rostest.rosrun("marl_mrta", "sim_lockstep", LockstepTest)
