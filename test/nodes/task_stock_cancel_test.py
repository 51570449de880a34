#!/usr/bin/env python3
"""rostest task_stock_cancel: a step's goal cancelled while stock move_base runs a recovery
behaviour ends that robot's goal, not the episode.

test/data/scenarios/blocked_goal_2r.xml: tb3_1 starts on A1's goal and stays there, so tb3_0's
stock move_base finds no plan to A1 and runs its recovery behaviours (a conservative reset after
planner_patience, then a full turn in place on sim time). The episode's 14 s end inside that turn,
and the manager cancels the goal. Stock move_base answers a cancel only between recovery
behaviours, so the manager lets sim time run until it has (the simulator is paused at a step's
end otherwise, and the turn would never end). Asserted: the turn was running when the step's
time was up; the step returns a goal timeout for tb3_0, the episode ends by its timeout, not
aborted; the next reset and step run. Skipped where the stock packages are not installed."""
import os
import sys
import threading

import rospy
from rosgraph_msgs.msg import Log

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from nav_goals_test import rosrun_marking_skips  # noqa: E402
from stock_test_helpers import StockGraphCase  # noqa: E402

from marl_mrta.ros.env_client import RosTaskEnvClient  # noqa: E402

MANAGER = "/rl_task_allocation_manager"
TURN_STARTED = "Rotate recovery behavior started"


class StockCancelTest(StockGraphCase):
    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        cls.turns = []   # sim time of each rotate recovery tb3_0's move_base started
        cls.turn_lock = threading.Lock()
        if cls.available:
            # /rosout: rostest starts no rosout node, so /rosout_agg carries nothing.
            rospy.Subscriber("/rosout", Log, cls.on_warning, queue_size=1000)

    @classmethod
    def on_warning(cls, msg):
        if msg.name == "/tb3_0/move_base" and TURN_STARTED in msg.msg:
            with cls.turn_lock:
                cls.turns.append(msg.header.stamp.to_sec())

    def test_a_goal_cancelled_in_a_recovery_behaviour_ends_as_a_goal_timeout(self):
        env = RosTaskEnvClient(MANAGER, wait_wall=240.0)
        self.assert_runs_stock("/tb3_0/move_base", "move_base", "move_base")
        scenario = env.scenario
        none = env.n_actions - 1
        env.reset(seed=0)
        step_end = rospy.get_time() + scenario.episode_timeout   # sim time (use_sim_time)
        out = env.step([scenario.task_index("A1"), none])
        self.assertEqual("", out.info.abort_reason)
        self.assertTrue(out.truncated)                       # by the episode's timeout
        self.assertFalse(out.info.reached[0])
        self.assertEqual("goal timeout", out.info.failure[0])
        self.assertAlmostEqual(out.info.elapsed, scenario.episode_timeout, delta=0.2)
        with self.turn_lock:
            turns = list(self.turns)
        # A turn lasts at least 2π / 1 rad/s (rotate_recovery's speed limit): one that started
        # in the step's last 6 s was running when the step's time was up.
        self.assertTrue(any(step_end - 6.0 < t < step_end for t in turns),
                        "no rotate recovery of tb3_0 was running at the step's end (sim time %.1f s): %s"
                        % (step_end, turns))
        # The graph goes on: a new episode, and tb3_0 reaches a goal that is free.
        env.reset(seed=1)
        out = env.step([scenario.task_index("A2"), none])
        self.assertEqual("", out.info.abort_reason)
        self.assertTrue(out.info.reached[0])


if __name__ == "__main__":
    rospy.init_node("task_stock_cancel_test")
    rosrun_marking_skips("task_stock_cancel", StockCancelTest, sys.argv)
