#!/usr/bin/env python3
"""rostest: the simulator killed (SIGKILL) while robots drive ends the episode with a logged error
within 5 s of wall time, and the task manager does not hang: it keeps answering its services
(a reset reports the lost simulator, a step is refused) and stays alive.
"""
import os
import signal
import threading
import time
import unittest
import xmlrpc.client

import rosgraph
import rosnode
import rospy
import rostest
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log

from marl_mrta.ros.env_client import ManagerUnavailable, RosTaskEnvClient

MANAGER = "/rl_task_allocation_manager"
ABORT_WITHIN = 5.0   # s of wall time from the kill to the logged error (the bound)


class SimulatorLostTest(unittest.TestCase):
    def setUp(self):
        rospy.init_node("task_sim_lost_test")
        self.errors = []   # (wall time, text) of the manager's ERROR lines
        rospy.Subscriber("/rosout", Log, self.on_log, queue_size=100)
        self.truth = None
        rospy.Subscriber("/tb3_0/base_pose_ground_truth", Odometry, self.on_truth, queue_size=5)

    def on_log(self, msg):
        if msg.name == MANAGER and msg.level >= Log.ERROR:
            self.errors.append((time.monotonic(), msg.msg))

    def on_truth(self, msg):
        self.truth = msg

    def simulator_pid(self):
        master = rosgraph.Master("/task_sim_lost_test")
        uri = rosnode.get_api_uri(master, "/simulator")
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/task_sim_lost_test")
        self.assertEqual(code, 1)
        return pid

    def test_killed_simulator_aborts_the_episode_and_the_manager_keeps_answering(self):
        env = RosTaskEnvClient(MANAGER, wait_wall=240.0)
        scenario = env.scenario
        env.reset(seed=0)
        start_x = self.truth.pose.pose.position.x if self.truth else None
        result = {}

        def far_step():   # both robots to the far side of the door: a long step
            try:
                result["output"] = env.step([scenario.task_index("B2"), scenario.task_index("B4")])
            except ManagerUnavailable as error:
                result["error"] = error

        stepper = threading.Thread(target=far_step, daemon=True)
        stepper.start()
        deadline = time.monotonic() + 120.0
        while self.truth is None or abs(self.truth.pose.pose.position.x - (start_x or 0.5)) < 0.3:
            self.assertLess(time.monotonic(), deadline, "the robot did not start driving")
            time.sleep(0.01)
        os.kill(self.simulator_pid(), signal.SIGKILL)
        killed = time.monotonic()

        stepper.join(60.0)
        self.assertFalse(stepper.is_alive(), "the step service did not return after the simulator was killed")
        self.assertNotIn("error", result)
        output = result["output"]
        self.assertTrue(output.truncated)
        self.assertFalse(output.done)
        reason = output.info.abort_reason
        self.assertIn("/clock", reason)
        self.assertEqual(output.info.episode.abort_reason, reason)

        deadline = time.monotonic() + 10.0
        while not any("episode aborted" in text for _, text in self.errors):
            self.assertLess(time.monotonic(), deadline, "no ERROR line from the manager")
            time.sleep(0.05)
        logged = min(t for t, text in self.errors if "episode aborted" in text)
        self.assertLessEqual(logged - killed, ABORT_WITHIN, "the abort was logged %.1f s after the kill"
                             % (logged - killed))

        # Still answering: a reset says the simulator is gone, a step is refused, the node lives.
        asked = time.monotonic()
        with self.assertRaises(ManagerUnavailable) as reset_error:
            env.reset(seed=1)
        self.assertIn("simulator", str(reset_error.exception))
        self.assertLess(time.monotonic() - asked, 30.0)
        with self.assertRaises(ManagerUnavailable) as step_error:
            env.step([0, 1])
        self.assertIn("no episode running", str(step_error.exception))
        self.assertTrue(rosnode.rosnode_ping(MANAGER, max_count=1))


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "task_sim_lost", SimulatorLostTest)
