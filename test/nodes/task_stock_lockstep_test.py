#!/usr/bin/env python3
"""rostest task_stock_lockstep: two exact episodes of lab_2r with stock move_base in the
simulator's lock-step (tasks.launch nav:=stock lockstep:=true rtf:=0; a stock_lockstep node per
robot holds the simulator on each control tick until that robot's cmd_vel has come). Both
episodes complete every task in precedence order; no node of the graph logs at ERROR level;
stock move_base never warns that its control loop missed its rate, which it does within seconds
when the simulator runs on at rtf 0 without waiting for its commands. Nothing here asserts speed.

Without the stock packages (``~stock_available`` false) the test is skipped, and the skip is
written into the JUnit result file as such (nav_goals_test's rosrun_marking_skips)."""
import os
import shutil
import sys
import tempfile

import rospy
from rosgraph_msgs.msg import Log

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from nav_goals_test import rosrun_marking_skips  # noqa: E402
from stock_test_helpers import StockGraphCase  # noqa: E402

from marl_mrta.ros.env_client import RosTaskEnvClient  # noqa: E402

MANAGER = "/rl_task_allocation_manager"
ROBOTS = ("tb3_0", "tb3_1")   # lab_2r
LATE_CONTROL = "Control loop missed its desired rate"


class StockLockstepEpisodeTest(StockGraphCase):
    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        cls.tmp = tempfile.mkdtemp(prefix="task_stock_lockstep_")
        cls.late = []
        if cls.available:
            rospy.Subscriber("/rosout", Log, cls.on_warning, queue_size=1000)

    @classmethod
    def on_warning(cls, msg):
        if LATE_CONTROL in msg.msg:
            with cls.lock:
                cls.late.append("%s: %s" % (msg.name, msg.msg.strip()))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_exact_episodes_complete_in_lock_step_without_errors_or_late_control(self):
        self.assertTrue(rospy.get_param("/simulator/lockstep"))
        RosTaskEnvClient(MANAGER, wait_wall=240.0)   # the manager is up, every move_base connected
        for robot in ROBOTS:
            self.assert_runs_stock("/%s/move_base" % robot, "move_base", "move_base")
        self.assert_exact_episodes_complete_in_order(2, self.tmp)
        self.assert_no_error_logged()
        with self.lock:
            self.assertEqual([], self.late, "stock move_base fell behind the simulator:\n  " + "\n  ".join(self.late[:5]))


if __name__ == "__main__":
    rospy.init_node("task_stock_lockstep_test")
    rosrun_marking_skips("task_stock_lockstep", StockLockstepEpisodeTest, sys.argv)
