#!/usr/bin/env python3
"""rostest: robots named by their scenario (burger_a, ops/burger_b) in the ROS simulation.

Before, the simulator and navigation always ran tb3_0 ... and the task manager stopped the
graph: "the simulator has no robot burger_a, ops/burger_b".
"""
import unittest

import rosgraph
import rospy
import rostest

from marl_mrta.ros.env_client import RosTaskEnvClient

MANAGER = "/rl_task_allocation_manager"
ROBOTS = ("burger_a", "ops/burger_b")


class TaskNamedRobotsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("task_named_robots_test")
        cls.env = RosTaskEnvClient(MANAGER, wait_wall=240.0)

    def test_the_graph_runs_the_scenarios_names(self):
        self.assertEqual(rospy.get_param("/simulator/robot_names"), " ".join(ROBOTS))
        published = {name for name, _ in rosgraph.Master("/task_named_robots_test").getPublishedTopics("")}
        for robot in ROBOTS:
            for topic in ("odom", "scan", "cmd_vel", "move_base/status"):
                self.assertIn(f"/{robot}/{topic}", published)
        self.assertFalse([t for t in published if t.startswith("/tb3_")])

    def test_an_episode_finishes_in_order(self):
        env = self.env
        a1, a2, b1, c1 = (env.scenario.task_index(name) for name in ("A1", "A2", "B1", "C1"))
        none = env.scenario.n_tasks
        env.reset(seed=0)
        out = None
        for joint in ([a1, a2], [b1, none], [c1, none]):
            out = env.step(joint)
            self.assertEqual(out.info.correct_order, [True, True])
        self.assertTrue(out.done)
        self.assertTrue(all(out.info.finished))


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "task_named_robots", TaskNamedRobotsTest)
