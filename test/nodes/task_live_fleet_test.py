#!/usr/bin/env python3
"""rostest: a live fleet in the ROS simulation (lab_2r, lock-step in real time, built-in navigation,
each move_base a process of its own, event mode, allocator replan, on_robot_fault continue).

One episode, driven from outside through the task manager's services while the robots work:
- bad submissions (an unknown predecessor, a cycle, a goal off the map, a goal in an obstacle, a
  duplicate id) are each refused in one line, and the schedule (~fleet_status: the tasks, their
  predecessors and goals) is as it was;
- X1, submitted mid-episode (a task finished) after B1, is done, and not before B1 is finished;
- B4, cancelled before any robot reached it, is never started;
- tb3_1's move_base process is SIGKILLed while tb3_1 drives to a task: tb3_1 leaves the fleet,
  that task is shown orphaned, then done by tb3_0, and tb3_0 drives on meanwhile (its true pose
  moves after the kill);
- the rviz markers show the submitted, the cancelled task and the robot that left;
- in the result document the episode is complete, and every task started after its predecessors
  finished (the predecessors as the final status gives them).
Waiting is bounded in wall time; nothing here asserts speed.
"""
import copy
import json
import math
import os
import signal
import sys
import threading
import time
import unittest

import rosgraph
import rospy
import rostest
import xmlrpc.client
from nav_msgs.msg import Odometry
from visualization_msgs.msg import MarkerArray

from marl_mrta.msg import FleetStatus, TaskRequest
from marl_mrta.srv import CancelTask, SubmitTasks

MANAGER = "/rl_task_allocation_manager"


def schedule(msg):
    """What a refused request must not change: the tasks, their predecessors and goals."""
    return sorted((t.id, t.category, tuple(t.predecessors), round(t.x, 6), round(t.y, 6), t.status == "cancelled")
                  for t in msg.tasks)


class Watch:
    """Every ~fleet_status, the latest markers, and tb3_0's true pose over wall time."""

    def __init__(self):
        self.lock = threading.Lock()
        self.statuses, self.markers, self.tb3_0 = [], None, []
        rospy.Subscriber(MANAGER + "/fleet_status", FleetStatus, self._on_status, queue_size=1000)
        rospy.Subscriber("/task_markers", MarkerArray, self._on_markers, queue_size=10)
        rospy.Subscriber("/tb3_0/base_pose_ground_truth", Odometry, self._on_pose, queue_size=10)

    def _on_status(self, msg):
        with self.lock:
            self.statuses.append(msg)

    def _on_markers(self, msg):
        with self.lock:
            self.markers = msg

    def _on_pose(self, msg):
        p = msg.pose.pose.position
        with self.lock:
            self.tb3_0.append((time.monotonic(), p.x, p.y))

    def latest(self):
        with self.lock:
            return copy.deepcopy(self.statuses[-1]) if self.statuses else None

    def all(self):
        with self.lock:
            return list(self.statuses)

    def wait(self, predicate, timeout, what):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            status = self.latest()
            if status is not None and predicate(status):
                return status
            time.sleep(0.02)
        raise AssertionError("timed out waiting for " + what)


def task(msg, task_id):
    return next((t for t in msg.tasks if t.id == task_id), None)


def robot(msg, robot_id):
    return next(r for r in msg.robots if r.id == robot_id)


def kill_move_base(ns):
    caller = rospy.get_name()
    uri = rosgraph.Master(caller).lookupNode("/%s/move_base" % ns)
    code, _, pid = xmlrpc.client.ServerProxy(uri).getPid(caller)
    assert code == 1, "no pid of /%s/move_base" % ns
    os.kill(pid, signal.SIGKILL)
    return time.monotonic()


class LiveFleetTest(unittest.TestCase):
    def test_a_live_fleet(self):
        rospy.init_node("task_live_fleet_test")
        watch = Watch()
        submit = rospy.ServiceProxy(MANAGER + "/submit_tasks", SubmitTasks)
        cancel = rospy.ServiceProxy(MANAGER + "/cancel_task", CancelTask)
        submit.wait_for_service(240.0)
        first = watch.wait(lambda s: s.running and s.allocator == "replan", 240.0, "the episode to start")
        self.assertEqual(sorted(t.id for t in first.tasks), ["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"])

        # Bad input: refused in one line, naming the task; the schedule as it was.
        bad = {
            "unknown predecessor": [TaskRequest("Y1", "A", 1.2, 2.5, 0.0, 0.0, ["Z9"])],
            "cycle": [TaskRequest("Y2", "A", 1.2, 2.5, 0.0, 0.0, ["Y3"]), TaskRequest("Y3", "A", 2.0, 2.5, 0.0, 0.0, ["Y2"])],
            "off the map": [TaskRequest("Y4", "A", 99.0, 2.5, 0.0, 0.0, [])],
            "in an obstacle": [TaskRequest("Y5", "A", 1.75, 1.5, 0.0, 0.0, [])],
            "duplicate id": [TaskRequest("A1", "A", 1.2, 2.5, 0.0, 0.0, [])],
        }
        for case, tasks in bad.items():
            before = schedule(watch.latest())
            answer = submit(tasks)
            rospy.loginfo("%s: %s", case, answer.message)
            self.assertFalse(answer.ok, case)
            self.assertEqual(len(answer.message.splitlines()), 1, case)
            self.assertTrue(any(t.id in answer.message for t in tasks), "%s: %s" % (case, answer.message))
            self.assertEqual(schedule(watch.latest()), before, case)

        # Mid-episode (a task finished, tb3_1 driving): a task submitted after B1; B4 cancelled
        # before any robot reaches it.
        watch.wait(lambda s: any(t.status == "finished" for t in s.tasks) and robot(s, "tb3_1").status == "driving",
                   180.0, "a task finished while tb3_1 drives")
        answer = submit([TaskRequest("X1", "A", 1.2, 2.5, 0.0, 1.0, ["B1"])])
        self.assertTrue(answer.ok, answer.message)
        status = watch.wait(lambda s: task(s, "X1") is not None, 10.0, "X1 in the status")
        self.assertTrue(task(status, "X1").submitted)
        self.assertGreater(task(status, "X1").released_at, 0.0)   # known mid-episode, not from the start
        self.assertEqual(task(status, "X1").predecessors, ["B1"])
        b4 = task(watch.latest(), "B4")
        self.assertIn(b4.status, ("open", "ready", "driving"), "B4 must not have been reached yet")
        answer = cancel("B4")
        self.assertTrue(answer.ok, answer.message)
        watch.wait(lambda s: task(s, "B4").status == "cancelled", 10.0, "B4 cancelled")

        # tb3_1's move_base killed while it drives to a task.
        status = watch.wait(lambda s: robot(s, "tb3_1").status == "driving", 120.0, "tb3_1 driving")
        victim = robot(status, "tb3_1").task
        killed = kill_move_base("tb3_1")
        rospy.loginfo("killed tb3_1's move_base while it drove to %s", victim)
        left = watch.wait(lambda s: robot(s, "tb3_1").status == "left", 60.0, "tb3_1 to leave the fleet")
        self.assertIn("move_base gone", robot(left, "tb3_1").left_reason)
        final = watch.wait(lambda s: not s.running and s.elapsed > 0.0, 400.0, "the episode's end")

        # The victim's task was orphaned, then done by tb3_0.
        self.assertTrue(any(task(s, victim) is not None and task(s, victim).orphaned for s in watch.all()),
                        "%s was never shown orphaned" % victim)
        self.assertEqual(task(final, victim).status, "finished")
        self.assertEqual(task(final, victim).robot, "tb3_0")
        # tb3_0 drove on after the kill.
        with watch.lock:
            after = [(x, y) for t, x, y in watch.tb3_0 if t > killed + 1.0]
            at_kill = [(x, y) for t, x, y in watch.tb3_0 if t <= killed][-1]
        self.assertTrue(any(math.hypot(x - at_kill[0], y - at_kill[1]) > 0.5 for x, y in after),
                        "tb3_0 did not move after the kill")

        # X1 done after B1; B4 never started; every task after its predecessors.
        self.assertEqual(task(final, "X1").status, "finished")
        self.assertGreaterEqual(task(final, "X1").start, task(final, "B1").finish)
        self.assertEqual(task(final, "B4").status, "cancelled")
        self.assertEqual(task(final, "B4").start, -1.0)
        for t in final.tasks:
            if t.status == "finished":
                for p in t.predecessors:
                    self.assertGreaterEqual(t.start + 1e-9, task(final, p).finish, "%s before %s" % (t.id, p))

        # The markers: the submitted task's ring, the cancelled task's cross, the robot that left.
        with watch.lock:
            spaces = {m.ns for m in watch.markers.markers}
        self.assertTrue({"tasks/submitted", "tasks/cancelled", "tasks/left_robots"} <= spaces, spaces)

        # The result document: the episode complete, B4 never reached, the events in the record.
        out = rospy.get_param(MANAGER + "/out")
        deadline = time.monotonic() + 60.0
        while not os.path.isfile(out) and time.monotonic() < deadline:
            time.sleep(0.2)
        with open(out) as handle:
            document = json.load(handle)
        record = document["results"][0]["episode_records"][0]
        self.assertEqual(document["allocator"], "replan")
        self.assertTrue(record["complete"], record["abort_reason"])
        b4_index = record["task_ids"].index("B4")
        self.assertFalse(any(e["task"] == b4_index and e["service_start"] is not None for e in record["entries"]))
        events = [(e["event"], e["subject"]) for e in record["fleet_events"]]
        for expected in (("submitted", "X1"), ("cancelled", "B4"), ("left", "tb3_1")):
            self.assertIn(expected, events)
        self.assertEqual(sum(1 for event, _ in events if event == "refused"), len(bad))
        for path in (out, document["results"][0]["gantt"]):
            os.remove(path)


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "task_live_fleet", LiveFleetTest, sys.argv)
