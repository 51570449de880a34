#!/usr/bin/env python3
"""rostest: full task-allocation episodes on lab_2r in the ROS simulation with built-in navigation.

- exact: the evaluation command with the ros executor runs the exact schedule to a complete,
  logic-consistent episode; meanwhile /Global_assigned_task, /<robot>/goal,
  /Global_reached_task, /idle_time and /task_markers carry what the episode record says;
- random: the random baseline runs an episode to its end (all tasks or the timeout) through
  RosTaskEnvClient, never aborted, every finished task reported once;
- repeat: the graph's first exact episode and the next one end on the same tick;
- reset: after robots have driven, ~reset puts them back on the scenario's start poses;
- idle steps: a step in which every robot chose None runs exactly min_step of sim time.
Waiting is bounded in wall time; nothing here asserts speed.
"""
import json
import math
import os
import tempfile
import threading
import time
import unittest

import rosgraph
import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from visualization_msgs.msg import Marker, MarkerArray

from marl_mrta.baselines.random_policy import RandomPolicy
from marl_mrta.apps.evaluate import main as evaluate_main
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.msg import IdleTime, TaskAssignment, TaskReached
from marl_mrta.srv import StepSim
from marl_mrta.ros import markers
from marl_mrta.ros.env_client import RosTaskEnvClient
from marl_mrta.ros.sim_link import quaternion_to_yaw

MANAGER = "/rl_task_allocation_manager"


class Recorder:
    """Every message of the paper's topics, in arrival order."""

    def __init__(self, robots):
        self.lock = threading.Lock()
        self.assigned, self.reached, self.idle, self.goals, self.markers = [], [], [], [], None
        rospy.Subscriber("/Global_assigned_task", TaskAssignment, self._add, "assigned", queue_size=100)
        rospy.Subscriber("/Global_reached_task", TaskReached, self._add, "reached", queue_size=100)
        rospy.Subscriber("/idle_time", IdleTime, self._add, "idle", queue_size=100)
        rospy.Subscriber("/task_markers", MarkerArray, self._on_markers, queue_size=10)
        for ns in robots:
            rospy.Subscriber("/%s/goal" % ns, PoseStamped, lambda msg, ns=ns: self._add((ns, msg), "goals"),
                             queue_size=100)

    def _add(self, msg, name):
        with self.lock:
            getattr(self, name).append(msg)

    def _on_markers(self, msg):
        with self.lock:
            self.markers = msg

    def clear(self):
        with self.lock:
            self.assigned, self.reached, self.idle, self.goals = [], [], [], []


class TaskEpisodesTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("task_episodes_test")
        cls.env = RosTaskEnvClient(MANAGER, wait_wall=240.0)
        cls.scenario = cls.env.scenario
        cls.robots = rospy.get_param(MANAGER + "/env")["robots"]
        cls.recorder = Recorder(cls.robots)
        cls.truth = {}
        for ns in cls.robots:
            rospy.Subscriber("/%s/base_pose_ground_truth" % ns, Odometry, cls._on_truth, ns, queue_size=5)
        rospy.rostime.wallsleep(1.0)   # subscriptions connect

    @classmethod
    def _on_truth(cls, msg, ns):
        cls.truth[ns] = msg

    def wait_for(self, predicate, wall, what):
        deadline = time.monotonic() + wall
        while not predicate():
            self.assertLess(time.monotonic(), deadline, "timed out waiting for " + what)
            rospy.rostime.wallsleep(0.05)

    def run_exact(self, episodes):
        """The evaluation command's exact episodes through the manager; its result document."""
        out = os.path.join(tempfile.mkdtemp(), "exact.json")
        code = evaluate_main(["--executor", "ros", "--method", "exact", "--episodes", str(episodes), "--out", out,
                              "--quiet"])
        self.assertEqual(code, 0)
        with open(out) as f:
            return json.load(f)

    def test_the_manager_follows_the_lock_step_answers(self):
        # One arena: the clock is paused between steps, and a step starts only on a tick every
        # controller has answered; that is what makes test_exact_episodes_repeat_to_the_tick hold.
        _, subscriptions, _ = rosgraph.Master("/task_episodes_test").getSystemState()
        self.assertIn("/rl_task_allocation_manager", dict(subscriptions).get("/simulator/lockstep_ack", []))

    def test_exact_episodes_repeat_to_the_tick(self):
        # Runs first (name order): the graph's first episode, started from launch, must equal the
        # next one, started from a reset after driving (lock-step: no dependence on history or load).
        episodes = self.run_exact(2)["results"][0]["episodes"]
        self.assertEqual([e["complete"] for e in episodes], [True, True])
        self.assertAlmostEqual(episodes[0]["makespan"], episodes[1]["makespan"], places=6,
                               msg="makespans of the first and second exact episode: %s" % [e["makespan"] for e in episodes])

    def test_exact_schedule_completes_and_topics_match_the_record(self):
        self.recorder.clear()
        data = self.run_exact(1)
        self.assertEqual(data["executor"], "ros")
        self.assertEqual(data["profile"], "ideal")   # the simulator's, which the episode ran under
        summary = data["results"][0]["summary"]
        self.assertEqual(summary["complete_pct"], 100.0)
        self.assertEqual(summary["logic_consistent_pct"], 100.0)
        record = data["results"][0]["representative_episode"]
        steps = record["decision_steps"]
        task_ids = record["task_ids"]
        finished = [e for e in record["entries"] if e["finished"]]
        self.wait_for(lambda: len(self.recorder.idle) >= steps and len(self.recorder.reached) >= len(finished),
                      10.0, "the last step's messages")
        rec = self.recorder
        with rec.lock:
            # /Global_assigned_task: one message per step, the joint action by task id ("" = None).
            self.assertEqual([list(m.tasks) for m in rec.assigned],
                             [[t or "" for t in step] for step in record["joint_actions"]])
            self.assertEqual([m.step for m in rec.assigned], list(range(steps)))
            self.assertTrue(all(list(m.robots) == self.robots for m in rec.assigned))
            # /<robot>/goal: the goal pose of every task a robot was sent to, in order.
            for i, ns in enumerate(self.robots):
                sent = [t for step in record["joint_actions"] for t in [step[i]] if t]
                goals = [msg for robot, msg in rec.goals if robot == ns]
                self.assertEqual(len(goals), len(sent))
                for task_id, msg in zip(sent, goals):
                    task = self.scenario.tasks[task_ids.index(task_id)]
                    self.assertEqual(msg.header.frame_id, "map")
                    self.assertAlmostEqual(msg.pose.position.x, task.goal.x, places=6)
                    self.assertAlmostEqual(msg.pose.position.y, task.goal.y, places=6)
                    self.assertAlmostEqual(quaternion_to_yaw(msg.pose.orientation), task.goal.yaw, places=5)
            # /Global_reached_task: every finished task once, with its robot, order and logic flag.
            reached = sorted((m.order, m.robot, m.task, m.logic_correct) for m in rec.reached)
            expected = sorted((e["order"], self.robots[e["robot"]], task_ids[e["task"]], e["logic_correct"])
                              for e in finished)
            self.assertEqual(reached, expected)
            self.assertEqual([r[0] for r in reached], list(range(1, len(task_ids) + 1)))
            # /idle_time: one message per step; summed per robot, the record's idle time.
            self.assertEqual([m.step for m in rec.idle], list(range(1, steps + 1)))
            for i in range(len(self.robots)):
                self.assertAlmostEqual(sum(m.idle_time[i] for m in rec.idle), record["idle_time"][i], places=6)
            # /task_markers: every task drawn as done (green), no robot -> goal line left.
            discs = [m for m in rec.markers.markers if m.ns.endswith("/goals")]
            self.assertEqual(len(discs), len(task_ids))
            for d in discs:
                for got, want in zip((d.color.r, d.color.g, d.color.b), (markers.DONE.r, markers.DONE.g, markers.DONE.b)):
                    self.assertAlmostEqual(got, want, places=5, msg=d.text)
            arrows = [m for m in rec.markers.markers if m.ns.endswith("/precedence")]
            self.assertEqual(len(arrows), sum(len(p) for p in self.scenario.predecessors))
            lines = [m for m in rec.markers.markers if m.ns.endswith("/robot_goal")]
            self.assertTrue(all(m.action == Marker.DELETE for m in lines))

    def test_random_schedule_runs_a_full_episode(self):
        self.recorder.clear()
        env = self.env
        policy = RandomPolicy(env.n_agents, env.n_tasks, seed=1)
        record = run_episodes(env, policy, 1, seed=1)[0]
        self.assertEqual(record.abort_reason, "")
        self.assertTrue(record.complete or record.truncated)
        if record.truncated:
            self.assertGreaterEqual(record.makespan, self.scenario.episode_timeout - 1e-6)
        else:
            self.assertTrue(all(t is not None for t in record.finish_time))
        self.assertGreaterEqual(record.decision_steps, 1)
        finished = sorted(self.scenario.tasks[e.task].id for e in record.entries if e.finished)
        self.wait_for(lambda: len(self.recorder.idle) >= record.decision_steps, 10.0, "/idle_time")
        with self.recorder.lock:
            self.assertEqual(sorted(m.task for m in self.recorder.reached), finished)

    def test_reset_returns_robots_to_their_start_poses(self):
        env = self.env
        out = env.reset(seed=5)
        # Drive away (robot 0 to A2, robot 1 to B3), then reset.
        out = env.step([self.scenario.task_index("A2"), self.scenario.task_index("B3")])
        self.assertTrue(any(out.info.reached))
        moved = [math.hypot(self.truth[ns].pose.pose.position.x - r.start.x,
                            self.truth[ns].pose.pose.position.y - r.start.y)
                 for ns, r in zip(self.robots, self.scenario.robots)]
        self.assertGreater(min(moved), 1.0)
        stamp = rospy.get_time()
        out = env.reset(seed=6)
        self.assertEqual(out.info.step, 0)
        self.assertFalse(any(out.info.finished))
        # A ground truth stamped after `stamp` may still be one published before the reset took
        # effect (the clock runs on between the step and the reset): wait for the start poses.
        def at_start(ns, robot):
            position = self.truth[ns].pose.pose.position
            return (self.truth[ns].header.stamp.to_sec() > stamp
                    and math.hypot(position.x - robot.start.x, position.y - robot.start.y) < 1e-3)
        self.wait_for(lambda: all(at_start(ns, r) for ns, r in zip(self.robots, self.scenario.robots)), 10.0,
                      "ground truth at the start poses after the reset")
        for ns, robot in zip(self.robots, self.scenario.robots):
            pose = self.truth[ns].pose.pose
            self.assertAlmostEqual(pose.position.x, robot.start.x, delta=1e-3, msg=ns)
            self.assertAlmostEqual(pose.position.y, robot.start.y, delta=1e-3, msg=ns)
            self.assertAlmostEqual(quaternion_to_yaw(pose.orientation), robot.start.yaw, delta=1e-3, msg=ns)
            self.assertAlmostEqual(self.truth[ns].twist.twist.linear.x, 0.0, delta=1e-6)

    def test_steps_without_goals_run_exactly_min_step(self):
        # Time must not run while no goal is under way: a pause requested then lands a number of
        # ticks later that depends on the load, and the next step starts late (same seed,
        # different episode).
        env = self.env
        current_tick = lambda: rospy.ServiceProxy("/simulator/step", StepSim)(0).tick
        rate = float(rospy.get_param("/simulator/physics_rate"))
        none = [env.n_tasks] * env.n_agents
        env.reset(seed=3)
        env.step(none)
        ticks = [current_tick()]
        for _ in range(5):
            out = env.step(none)
            self.assertAlmostEqual(out.info.step_duration, env.settings.min_step)
            ticks.append(current_tick())
        self.assertEqual([b - a for a, b in zip(ticks, ticks[1:])], [round(env.settings.min_step * rate)] * 5)


if __name__ == "__main__":
    rostest.rosrun("marl_mrta", "task_episodes", TaskEpisodesTest)
