#!/usr/bin/env python3
"""rostest: hold_successors through the task manager (lab_2r, lock-step, built-in navigation).

B1 follows A1. A robot sent to B1 while A1 is open reaches it, serves nothing and breaks no
order; sent to B1 again (where it stands) in the step in which the other robot does A1, it
waits for A1's finish and serves B1 after it, and the step's message says how long it waited.
Under the paper's rules (task_episodes.test, the default) B1 would count as done out of order.
"""
import unittest

import rospy
import rostest

from marl_mrta.ros.env_client import RosTaskEnvClient

MANAGER = "/rl_task_allocation_manager"


class TaskHoldTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("task_hold_test")
        cls.env = RosTaskEnvClient(MANAGER, wait_wall=240.0)

    def test_a_robot_early_at_a_successor_waits_for_its_predecessor(self):
        env = self.env
        self.assertTrue(env.settings.hold_successors)
        a1, a3, b1 = (env.scenario.task_index(name) for name in ("A1", "A3", "B1"))
        env.reset(seed=0)
        out = env.step([b1, a3])
        self.assertEqual(out.info.reached, [True, True])
        self.assertEqual(out.info.correct_order, [True, True])
        self.assertFalse(out.info.finished[b1])
        self.assertEqual(out.info.finished_task, [None, a3])
        out = env.step([b1, a1])
        self.assertEqual(out.info.finished_task, [b1, a1])
        self.assertEqual(out.info.correct_order, [True, True])
        self.assertGreater(out.info.held_time[0], 1.0)   # A1 is metres away from A3
        self.assertEqual(out.info.held_time[1], 0.0)
        self.assertGreater(out.info.nav_time[1], out.info.nav_time[0] + out.info.held_time[0] - 1e-6)


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "task_hold", TaskHoldTest)
