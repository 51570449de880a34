#!/usr/bin/env python3
"""rostest task_stock_amcl: one exact episode of lab_2r with the stock move_base and stock amcl
(tasks.launch nav:=stock localization:=amcl, real time). The evaluation command runs it through
the task manager, which re-initialises each robot's amcl at the reset and waits for its estimate;
the episode completes every task in precedence order (logic-consistent), and no node of the graph
logs at ERROR level or above (/rosout). Nothing here asserts speed.

Without the stock packages (``~stock_available`` false) the test is skipped, and the skip is
written into the JUnit result file as such (nav_goals_test's rosrun_marking_skips)."""
import math
import os
import shutil
import sys
import tempfile

import rospkg
import rospy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from nav_goals_test import rosrun_marking_skips  # noqa: E402
from stock_test_helpers import StockGraphCase  # noqa: E402

from marl_mrta.model.scenario import load_scenario  # noqa: E402
from marl_mrta.ros.env_client import RosTaskEnvClient  # noqa: E402

MANAGER = "/rl_task_allocation_manager"
ROBOTS = ("tb3_0", "tb3_1")   # lab_2r


class StockAmclEpisodeTest(StockGraphCase):
    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        cls.tmp = tempfile.mkdtemp(prefix="task_stock_amcl_")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_exact_episode_completes_logic_consistent_without_errors(self):
        # Each amcl was started at its robot's start pose (before the manager re-initialises it at
        # the episode's reset). Its ~initial_pose_* is that, or its estimate since (saved at
        # save_pose_rate), which stays near it while the robot stands: one started at (0, 0, 0)
        # instead is off by metres.
        scenario = load_scenario(rospkg.RosPack().get_path("marl_mrta") + "/scenarios/lab_2r.xml")
        self.assertEqual([spec.id for spec in scenario.robots], list(ROBOTS))
        for robot, spec in zip(ROBOTS, scenario.robots):
            x, y, a = (rospy.get_param("/%s/amcl/initial_pose_%s" % (robot, k)) for k in "xya")
            start = spec.start
            self.assertLess(math.hypot(x - start.x, y - start.y), 0.15, "%s: amcl starts at (%.2f, %.2f), not at %s"
                            % (robot, x, y, start))
            self.assertLess(abs((a - start.yaw + math.pi) % (2 * math.pi) - math.pi), 0.15,
                            "%s: amcl starts with yaw %.2f, not %s" % (robot, a, start))
        RosTaskEnvClient(MANAGER, wait_wall=240.0)   # the manager is up, every amcl and move_base connected
        for robot in ROBOTS:
            self.assert_runs_stock("/%s/move_base" % robot, "move_base", "move_base")
            self.assert_runs_stock("/%s/amcl" % robot, "amcl", "amcl")
        self.assert_exact_episodes_complete_in_order(1, self.tmp)
        self.assert_no_error_logged()


if __name__ == "__main__":
    rospy.init_node("task_stock_amcl_test")
    rosrun_marking_skips("task_stock_amcl", StockAmclEpisodeTest, sys.argv)
