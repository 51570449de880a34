#!/usr/bin/env python3
"""rostest: event mode through the task manager (lab_2r, lock-step, built-in navigation).

- a robot that comes free decides at once: tb3_0's leg to A1 is a fraction of tb3_1's to B2 (beyond
  the door), and tb3_0's next goal goes out (its /tb3_0/goal, and its move_base goal) before tb3_1
  has arrived;
  the step says who decides and what the other drives to;
- the same routes with the same seed give the same episode twice, to the tick (lock-step);
- no task is finished before its predecessors, also where a robot reached a successor early and
  held there;
- evaluate.launch decision_mode:=event method:=exact runs the exact plan's episode to its end,
  complete and in order, with the paper's topics per event.
Waiting is bounded in wall time; nothing here asserts speed.
"""
import json
import os
import subprocess
import tempfile
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseActionGoal

from marl_mrta.msg import TaskAssignment, TaskReached
from marl_mrta.ros.env_client import RosTaskEnvClient

MANAGER = "/rl_task_allocation_manager"
ROBOTS = ("tb3_0", "tb3_1")
# Per robot the tasks it takes in turn; tb3_1 reaches B4 before tb3_0 has finished A4, and waits.
ROUTES = (("A1", "A2", "B1", "A4", "A3"), ("B2", "B4", "B3"))


class Recorder:
    def __init__(self):
        self.lock = threading.Lock()
        self.goals = {ns: [] for ns in ROBOTS}        # /<robot>/goal: (stamp, x, y)
        self.base_goals = {ns: [] for ns in ROBOTS}   # /<robot>/move_base/goal stamps
        self.assigned, self.reached = [], []
        for ns in ROBOTS:
            rospy.Subscriber("/%s/goal" % ns, PoseStamped, self._on_goal, ns, queue_size=100)
            rospy.Subscriber("/%s/move_base/goal" % ns, MoveBaseActionGoal, self._on_base_goal, ns, queue_size=100)
        rospy.Subscriber("/Global_assigned_task", TaskAssignment, self._add, "assigned", queue_size=100)
        rospy.Subscriber("/Global_reached_task", TaskReached, self._add, "reached", queue_size=100)

    def _on_goal(self, msg, ns):
        with self.lock:
            self.goals[ns].append((msg.header.stamp.to_sec(), msg.pose.position.x, msg.pose.position.y))

    def _on_base_goal(self, msg, ns):
        with self.lock:
            self.base_goals[ns].append(msg.header.stamp.to_sec())

    def _add(self, msg, name):
        with self.lock:
            getattr(self, name).append(msg)

    def clear(self):
        with self.lock:
            for ns in ROBOTS:
                self.goals[ns], self.base_goals[ns] = [], []
            self.assigned, self.reached = [], []


class TaskEventTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("task_event_test")
        cls.env = RosTaskEnvClient(MANAGER, wait_wall=240.0)
        cls.recorder = Recorder()
        rospy.rostime.wallsleep(1.0)   # subscriptions connect

    def run_routes(self, seed):
        """One episode of ROUTES; the first step's output and the episode's record."""
        env = self.env
        routes = [[env.scenario.task_index(t) for t in route] for route in ROUTES]
        output = env.reset(seed=seed)
        first = None
        for _ in range(100):
            actions = [env.n_tasks] * env.n_agents
            for robot in [i for i, deciding in enumerate(output.deciding) if deciding]:
                actions[robot] = next((t for t in routes[robot] if not output.info.finished[t]), env.n_tasks)
            output = env.step(actions)
            first = first or output
            if output.done or output.truncated:
                return first, output.info.episode
        self.fail("the episode did not end within 100 decision instants")

    def wait_for(self, predicate, what):
        for _ in range(200):   # 10 s of wall time
            if predicate():
                return
            rospy.rostime.wallsleep(0.05)
        self.fail("timed out waiting for " + what)

    def test_event_mode_in_the_ros_graph(self):
        env = self.env
        self.assertEqual(env.settings.decision_mode, "event")
        a1, b2 = env.scenario.task_index("A1"), env.scenario.task_index("B2")
        self.recorder.clear()
        first, record = self.run_routes(seed=0)

        # tb3_0 came free at A1 while tb3_1 still drove to A2: only tb3_0 decides.
        self.assertEqual(list(first.deciding), [True, False])
        self.assertEqual(first.info.robot_tasks, [None, b2])
        self.assertEqual(first.info.finished_task, [a1, None])
        self.assertTrue(record.complete, record.abort_reason)
        self.assertEqual(record.decision_mode, "event")
        reach_b2 = next(e.reach for e in record.entries if e.robot == 1 and e.task == b2)
        rec = self.recorder
        self.wait_for(lambda: len(rec.reached) >= env.n_tasks, "/Global_reached_task of every task")
        with rec.lock:
            goals, base_goals = list(rec.goals["tb3_0"]), list(rec.base_goals["tb3_0"])
        start = goals[0][0]   # the first goals go out at the episode's start
        self.assertGreaterEqual(len(goals), len(ROUTES[0]))
        a2 = env.scenario.tasks[env.scenario.task_index("A2")].goal
        self.assertAlmostEqual(goals[1][1], a2.x, places=6)
        self.assertAlmostEqual(goals[1][2], a2.y, places=6)
        self.assertLess(goals[1][0] - start, reach_b2 - 1.0,
                        "tb3_0's second goal must go out while tb3_1 still drives to B2")
        self.assertLess(base_goals[1] - start, reach_b2 - 1.0)

        # No task finished before its predecessors; tb3_1 held at B4 until A4 was finished.
        for task, predecessors in enumerate(env.scenario.predecessors):
            served = [e.service_start for e in record.entries if e.task == task and e.finished]
            self.assertEqual(len(served), 1, env.scenario.tasks[task].id)
            for p in predecessors:
                self.assertLessEqual(record.finish_time[p], served[0] + 1e-9, env.scenario.tasks[task].id)
        b4 = next(e for e in record.entries if e.task == env.scenario.task_index("B4") and e.finished)
        self.assertGreater(b4.service_start, b4.reach)
        with rec.lock:
            self.assertEqual(sorted(m.order for m in rec.reached), list(range(1, env.n_tasks + 1)))
            self.assertTrue(all(m.logic_correct for m in rec.reached))
            self.assertEqual(len(rec.assigned), record.decision_steps)

        # The same routes, the same seed: the same episode, to the tick.
        _, again = self.run_routes(seed=0)
        self.assertEqual(again.to_dict(), record.to_dict())

    def test_evaluate_launch_runs_the_exact_plan_in_event_mode(self):
        out = os.path.join(tempfile.mkdtemp(prefix="task_event_"), "exact.json")
        launch = subprocess.run(["roslaunch", "marl_mrta", "evaluate.launch", "method:=exact", "tasks:=false",
                                 "decision_mode:=event", "episodes:=1", "out:=" + out],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600)
        tail = launch.stdout[-3000:]
        self.assertTrue(os.path.isfile(out), "evaluate wrote no result:\n" + tail)
        with open(out) as handle:
            result = json.load(handle)
        self.assertEqual(result["decision_mode"], "event")
        summary = result["results"][0]["summary"]
        self.assertEqual(summary["complete_pct"], 100.0, tail)
        self.assertEqual(summary["logic_consistent_pct"], 100.0, tail)
        episode = result["results"][0]["representative_episode"]
        finish = episode["finish_time"]
        for task, predecessors in enumerate(self.env.scenario.predecessors):
            for p in predecessors:
                self.assertLessEqual(finish[p], finish[task])


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "task_event", TaskEventTest)
