#!/usr/bin/env python3
"""rostest real_gate: each real robot's cmd_vel gate (apps/cmd_vel_gate_node.py) against the stand-in.

1. A stop while stock move_base turns in rotate_recovery (stock navigation; skipped without it):
   test/data/scenarios/blocked_goal_2r.xml, where tb3_1 stands on A1. Once the manager waits for
   the operator's go, the test sends tb3_0's move_base a goal to A1 itself: no plan, a conservative
   reset, then rotate_recovery, which publishes its turn until it ends whatever the cancel. The
   e-stop comes during the turn. Asserted: move_base went on commanding the turn (cmd_vel_nav)
   after the stop, yet tb3_0's cmd_vel carried only zeros from at most 0.5 s after the e-stop, and
   its odometry stood still from 1 s after it; the gate's ~state said open before and why it
   closed after.
2. A task manager that hangs (SIGSTOP: nothing of its own stop runs, and nothing in the launch
   dies) while the robots drive (built-in navigation, which runs everywhere): the gates close once
   the permit is older than permit_timeout, cancel every goal and send zero cmd_vel; every robot's
   cmd_vel is zero for good within 0.5 s of that, no move_base goal is active afterwards, and each
   gate's ~state names the timeout. Let go again (SIGCONT), the manager finds its goals cancelled
   and ends the episode unfinished.
"""
import json
import os
import signal
import sys
import tempfile
import threading
import time
import unittest
from pathlib import Path

import actionlib
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus, GoalStatusArray
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log
from std_msgs.msg import String
from std_srvs.srv import Trigger

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from real_test_helpers import ROBOTS, CommandWatch, Recorder, node_pid, start_real_launch, wait_exit  # noqa: E402
from stock_test_helpers import UNAVAILABLE  # noqa: E402

from marl_mrta.common.config import read_yaml  # noqa: E402
from marl_mrta.common.paths import default_config_path, package_root  # noqa: E402
from marl_mrta.evaluation.sim_to_real import is_moving, stop_time  # noqa: E402
from marl_mrta.ros.process_group import stop_process_group  # noqa: E402

STOP_WITHIN = 0.5   # s from the moment the fault is known, as in real_stop
MANAGER = "/rl_task_allocation_manager"
PERMIT_TIMEOUT = read_yaml(default_config_path("cmd_vel_gate.yaml")).data["permit_timeout"]
BLOCKED = os.path.join(str(package_root()), "test", "data", "scenarios", "blocked_goal_2r.xml")


class RealGateTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("real_test")
        cls.watch = CommandWatch()
        cls.log_lock = threading.Lock()
        cls.log = []   # (wall time, node, message) of /rosout
        rospy.Subscriber("/rosout", Log, cls.on_log, queue_size=1000)

    @classmethod
    def on_log(cls, msg):
        with cls.log_lock:
            cls.log.append((time.monotonic(), msg.name, msg.msg))

    def wait_logged(self, node, text, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.log_lock:
                for t, name, message in self.log:
                    if name == node and text in message:
                        return t
            time.sleep(0.05)
        self.fail("%s never logged %r" % (node, text))

    @staticmethod
    def gate_state(ns):
        return rospy.wait_for_message("/%s/cmd_vel_gate/state" % ns, String, timeout=5.0).data

    def test_1_a_stop_holds_while_stock_rotate_recovery_turns(self):
        if not rospy.get_param("~stock_available", False):
            self.skipTest(UNAVAILABLE)
        work = tempfile.mkdtemp(prefix="real_gate_turn_")
        launch = start_real_launch(["stand_in:=true", "nav:=stock", "scenario:=" + BLOCKED, "method:=exact",
                                    "episodes:=1", "go:=false", "out:=" + os.path.join(work, "result.json")],
                                   os.path.join(work, "launch.log"))
        try:
            nav = Recorder("/tb3_0/cmd_vel_nav")
            odom = Recorder("/tb3_0/odom", Odometry)
            self.wait_logged(MANAGER, "waiting for the operator's go", 240.0)
            client = actionlib.SimpleActionClient("/tb3_0/move_base", MoveBaseAction)
            self.assertTrue(client.wait_for_server(rospy.Duration(30.0)))
            goal = MoveBaseGoal()
            goal.target_pose.header.frame_id = "map"
            goal.target_pose.header.stamp = rospy.Time.now()
            goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = 2.0, 0.6   # A1, where tb3_1 stands
            goal.target_pose.pose.orientation.w = 1.0
            client.send_goal(goal)
            self.assertEqual("open", self.gate_state("tb3_0"))
            turn = self.wait_logged("/tb3_0/move_base", "Rotate recovery behavior started", 60.0)
            deadline = time.monotonic() + 5.0
            while not any(abs(w) > 0.2 for _, _, w in nav.after(turn)):
                self.assertLess(time.monotonic(), deadline, "rotate_recovery sent no turn")
                time.sleep(0.02)
            estop = time.monotonic()
            self.assertTrue(rospy.ServiceProxy(MANAGER + "/estop", Trigger)().success)
            time.sleep(0.3)
            state = self.gate_state("tb3_0")   # now: the aborted episode ends real.launch in a second or two
            time.sleep(2.7)
            turning_on = [t - estop for t, v, w in nav.after(estop + STOP_WITHIN) if is_moving(v, w)]
            rospy.loginfo("move_base commanded the turn until %.2f s after the e-stop",
                          max(turning_on) if turning_on else 0.0)
            self.assertTrue(turning_on, "move_base's turn ended with the e-stop: nothing here to gate")
            self.assertEqual("closed: drive permit withdrawn (the fleet is stopped)", state)
            stopped = stop_time(self.watch.of("tb3_0"), estop - 1.0)
            self.assertIsNotNone(stopped, "tb3_0 still commanded to move after the e-stop")
            rospy.loginfo("tb3_0: cmd_vel zero for good %.3f s after the e-stop", stopped - estop)
            self.assertLessEqual(stopped - estop, STOP_WITHIN)
            moving = [(t - estop, w) for t, v, w in odom.after(estop + 1.0) if abs(v) > 0.01 or abs(w) > 0.05]
            self.assertEqual([], moving[:5], "tb3_0 still moved after the e-stop (s after it, rad/s)")
        finally:
            stop_process_group(launch)

    def test_2_a_task_manager_that_hangs_stops_every_robot(self):
        work = tempfile.mkdtemp(prefix="real_gate_kill_")
        out = os.path.join(work, "result.json")
        launch = start_real_launch(["stand_in:=true", "nav:=builtin", "method:=exact", "episodes:=2", "go:=true",
                                    "out:=" + out], os.path.join(work, "launch.log"))
        try:
            statuses = {ns: [] for ns in ROBOTS}
            for ns in ROBOTS:
                rospy.Subscriber("/%s/move_base/status" % ns, GoalStatusArray,
                                 lambda msg, ns=ns: statuses[ns].append((time.monotonic(), msg)), queue_size=10)
            self.assertTrue(self.watch.wait_driving(240.0), "the robots did not start driving")
            time.sleep(2.0)
            manager = node_pid(MANAGER)   # a stopped node cannot tell its pid
            os.kill(manager, signal.SIGSTOP)
            hung = time.monotonic()
            closed = hung + PERMIT_TIMEOUT
            time.sleep(PERMIT_TIMEOUT + 3.0)
            states = {ns: self.gate_state(ns) for ns in ROBOTS}
            os.kill(manager, signal.SIGCONT)
            for ns in ROBOTS:
                stopped = stop_time(self.watch.of(ns), hung)
                self.assertIsNotNone(stopped, "%s still commanded to move while the manager hung" % ns)
                rospy.loginfo("%s: cmd_vel zero for good %.3f s after the manager hung", ns, stopped - hung)
                self.assertLessEqual(stopped - closed, STOP_WITHIN, "%s: stopped %.3f s after the gate's timeout"
                                     % (ns, stopped - closed))
                self.assertRegex(states[ns], r"^closed: no drive permit for 1\.\d s \(the task manager is gone or hangs\)$")
                latest = [msg for t, msg in statuses[ns] if t > closed + 1.0]
                self.assertTrue(latest, "%s: move_base status silent" % ns)
                active = [s.goal_id.id for s in latest[-1].status_list if s.status == GoalStatus.ACTIVE]
                self.assertEqual([], active, "%s: goals still active after the gate closed" % ns)
            self.assertIsNotNone(wait_exit(launch, 120.0), "real.launch did not end after the manager went on")
            episodes = json.loads(Path(out).read_text())["results"][0]["episodes"]
            self.assertEqual(1, len(episodes))
            self.assertFalse(episodes[0]["complete"])
        finally:
            stop_process_group(launch)


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "real_gate", RealGateTest)
