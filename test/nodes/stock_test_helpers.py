"""What the rostests of the stock navigation stack share (nav_stock_test.py,
task_stock_amcl_test.py, task_stock_lockstep_test.py, task_stock_cancel_test.py): the skip when
the stock packages are missing (``~stock_available`` false, derived by the .test file), every
ERROR line the graph logs (on /rosout: rostest starts no rosout node, so /rosout_agg carries
nothing), that a node of the graph is the stock one (not the built-in drop-in under the same
name), and exact episodes through the evaluation command."""
import json
import os
import threading
import time
import unittest
import xmlrpc.client

import rosgraph
import rospy
from rosgraph_msgs.msg import Log
from roslib.packages import find_node

from marl_mrta.apps.evaluate import main as evaluate_main

UNAVAILABLE = "stock navigation not available (rospack finds no move_base, amcl or fake_localization; make stock-nav NAV_SRC=...)"


class StockGraphCase(unittest.TestCase):
    """A test case on a graph of stock nodes: skipped, with one line, without them; collects what
    any node but the test's own logs at ERROR level or above (the test's actionlib client may
    complain of stale goal status)."""

    @classmethod
    def setUpClass(cls):
        cls.available = rospy.get_param("~stock_available", False)
        cls.errors = []
        cls.lock = threading.Lock()
        if cls.available:
            rospy.Subscriber("/rosout", Log, cls.on_log, queue_size=1000)

    @classmethod
    def on_log(cls, msg):
        if msg.level >= Log.ERROR and msg.name != rospy.get_name():
            with cls.lock:
                cls.errors.append("%s: %s" % (msg.name, msg.msg.strip()))

    def setUp(self):
        if not self.available:
            self.skipTest(UNAVAILABLE)

    def assert_no_error_logged(self):
        time.sleep(1.0)  # wall: the last messages of /rosout arrive
        with self.lock:
            self.assertEqual([], self.errors, "logged at ERROR level:\n  " + "\n  ".join(self.errors))

    def assert_exact_episodes_complete_in_order(self, episodes, out_dir):
        """The evaluation command runs `episodes` exact episodes through the task manager: every
        one completes every task, in precedence order (logic-consistent)."""
        out = os.path.join(out_dir, "exact.json")
        code = evaluate_main(["--executor", "ros", "--method", "exact", "--episodes", str(episodes), "--out", out,
                              "--quiet"])
        self.assertEqual(code, 0, "evaluate failed")
        with open(out) as f:
            summary = json.load(f)["results"][0]["summary"]
        self.assertEqual(summary["complete_pct"], 100.0, summary)
        self.assertEqual(summary["logic_consistent_pct"], 100.0, summary)

    def assert_runs_stock(self, node, package, node_type):
        """`node` (a graph name) is a process of `package`'s `node_type` executable: the stock
        node, not marl_mrta's drop-in of the same name."""
        caller = rospy.get_name()
        pid = int(xmlrpc.client.ServerProxy(rosgraph.Master(caller).lookupNode(node)).getPid(caller)[2])
        running = os.path.realpath("/proc/%d/exe" % pid)
        stock = [os.path.realpath(p) for p in find_node(package, node_type)]
        self.assertIn(running, stock, "%s runs %s, not %s/%s" % (node, running, package, node_type))
