"""The task manager's topics (docs/reference/nodes_tasks.md): the paper's `Global_assigned_task`,
`Global_reached_task`, `/<robot>/goal` and `idle_time`, and the rviz `task_markers`.

In synchronous mode they follow the steps; in event mode the events: a robot's goal when it is
sent, a reach when a task is finished, and the markers drawn from the fleet's snapshot
(ros/fleet_status.py, kept by ros/fleet_services.py), which shows submitted, cancelled and orphaned
tasks and robots that left. While robots drive, a thread refreshes the robot -> goal lines.
"""
from __future__ import annotations

import threading
from typing import Callable, List, Optional, Sequence

import rospy
from geometry_msgs.msg import PoseStamped
from visualization_msgs.msg import MarkerArray

from marl_mrta.msg import IdleTime, TaskAssignment, TaskReached

from marl_mrta.env.api import StepOutput
from marl_mrta.ros.fleet_status import FleetSnapshot
from marl_mrta.ros.markers import fleet_markers, task_markers
from marl_mrta.ros.move_base_link import yaw_to_quaternion


class ManagerTopics:
    """`env`: the manager's environment (its scenario grows as tasks are submitted); `snapshot()`:
    the fleet's latest snapshot in event mode (None before the first episode)."""

    def __init__(self, env, executor, map_frame: str, marker_period: float,
                 snapshot: Callable[[], Optional[FleetSnapshot]]):
        self.env = env
        self.executor = executor
        self.map_frame = map_frame
        self.marker_period = marker_period
        self.snapshot = snapshot
        self.event = env.settings.decision_mode == "event"
        self.robot_ns = list(executor.namespaces)
        self._entries_seen = 0   # event mode: the record's entries published so far
        self._assigned: List[Optional[int]] = [None] * len(self.robot_ns)   # synchronous mode: the step's goals
        self._driving = threading.Event()
        self._marker_lock = threading.Lock()
        self.pub_assigned = rospy.Publisher("Global_assigned_task", TaskAssignment, queue_size=10, latch=True)
        self.pub_reached = rospy.Publisher("Global_reached_task", TaskReached, queue_size=50)
        self.pub_idle = rospy.Publisher("idle_time", IdleTime, queue_size=10)
        self.pub_goal = [rospy.Publisher("/" + ns + "/goal", PoseStamped, queue_size=1, latch=True)
                         for ns in self.robot_ns]
        self.pub_markers = rospy.Publisher("task_markers", MarkerArray, queue_size=1, latch=True)
        if self.event:   # goals go out one by one, as the executor sends them
            executor.goal_listener = self._on_goal_sent

    def start(self) -> None:
        self.publish_markers()
        if self.marker_period > 0.0:
            threading.Thread(target=self._refresh_markers, daemon=True, name="markers").start()

    # ------------------------------------------------------------------ episodes

    def episode_started(self) -> None:
        self._assigned = [None] * len(self.robot_ns)
        self._entries_seen = 0
        self.publish_markers()

    def before_step(self, goals: Sequence[Optional[int]]) -> None:
        """The step's goals (per robot a task index or None); in event mode only the deciding
        robots' count (the others drive on)."""
        now = rospy.Time.now()
        tasks = self.env.scenario.tasks
        if self.event:
            due = self.env.rules.due
            goals = [g if i in due else None for i, g in enumerate(goals)]
        self.pub_assigned.publish(TaskAssignment(stamp=now, step=self.env.step_index, robots=self.robot_ns,
                                                 tasks=[tasks[g].id if g is not None else "" for g in goals]))
        self._driving.set()
        if self.event:   # goals go out as they are sent (_on_goal_sent)
            return
        self._assigned = list(goals)
        for publisher, goal in zip(self.pub_goal, goals):
            if goal is not None:
                self._publish_goal(publisher, goal, now)
        self.publish_markers()

    def step_ended(self) -> None:
        with self._marker_lock:
            self._driving.clear()

    def after_step(self, output: StepOutput) -> None:
        if self.event:
            self._publish_events(output)
            return
        now = rospy.Time.now()
        info = output.info
        tasks = self.env.scenario.tasks
        for i, (task, order) in enumerate(zip(info.finished_task, info.finish_order)):
            if task is None:
                continue
            self.pub_reached.publish(TaskReached(stamp=now, robot=self.robot_ns[i], task=tasks[task].id,
                                                 order=int(order), logic_correct=bool(info.correct_order[i])))
        self.pub_idle.publish(IdleTime(stamp=now, step=int(info.step), robots=self.robot_ns,
                                       idle_time=[float(t) for t in info.idle_time]))
        if self.env.settings.hold_successors:   # why a robot stood at its task
            for i, goal in enumerate(self._assigned):
                if goal is not None and info.reached[i] and not info.finished[goal]:
                    rospy.loginfo("%s at %s: a predecessor is not finished; the task stays open", self.robot_ns[i],
                                  tasks[goal].id)
                elif info.held_time[i] > 0.0:
                    rospy.loginfo("%s waited %.2f s at %s for its predecessors", self.robot_ns[i], info.held_time[i],
                                  tasks[goal].id)
        self._assigned = [None] * len(self.robot_ns)
        self.publish_markers()

    # ------------------------------------------------------------------ helpers

    def _publish_goal(self, publisher, task: int, stamp) -> None:
        msg = PoseStamped()
        msg.header.stamp, msg.header.frame_id = stamp, self.map_frame
        pose = self.env.scenario.tasks[task].goal
        msg.pose.position.x, msg.pose.position.y = pose.x, pose.y
        o = msg.pose.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(pose.yaw)
        publisher.publish(msg)

    def _on_goal_sent(self, robot: int, task: int) -> None:
        """Event mode: the executor sent the robot its goal (and move_base took it)."""
        self._publish_goal(self.pub_goal[robot], task, rospy.Time.now())

    def _publish_events(self, output: StepOutput) -> None:
        """Event mode: each task finished since the last step (its order from the record), the
        transition's idle time, and the markers."""
        now = rospy.Time.now()
        record = self.env.record
        tasks = self.env.scenario.tasks
        for entry in record.entries[self._entries_seen:]:
            if entry.finished:
                self.pub_reached.publish(TaskReached(stamp=now, robot=self.robot_ns[entry.robot],
                                                     task=tasks[entry.task].id, order=int(entry.order),
                                                     logic_correct=bool(entry.logic_correct)))
                if entry.service_start is not None and entry.reach is not None and entry.service_start > entry.reach:
                    rospy.loginfo("%s waited %.2f s at %s for its predecessors", self.robot_ns[entry.robot],
                                  entry.service_start - entry.reach, tasks[entry.task].id)
        self._entries_seen = len(record.entries)
        self.pub_idle.publish(IdleTime(stamp=now, step=int(output.info.step), robots=self.robot_ns,
                                       idle_time=[float(t) for t in output.info.idle_time]))
        if not (output.done or output.truncated) and any(t is not None for t in output.info.robot_tasks):
            self._driving.set()   # markers follow the robots between steps too (real robots drive on)
        self.publish_markers()

    def publish_markers(self, only_while_driving: bool = False) -> None:
        with self._marker_lock:   # the refresh thread never publishes an older state after a newer one
            if only_while_driving and not self._driving.is_set():
                return
            env = self.env
            if env.record is None:   # real robots: no episode yet
                return
            xy = [(p[0], p[1]) for p in self.executor.poses()]
            if self.event:
                snapshot = self.snapshot()
                if snapshot is not None:
                    self.pub_markers.publish(fleet_markers(snapshot, self.map_frame, rospy.Time.now(), xy))
                return
            self.pub_markers.publish(task_markers(env.scenario, self.map_frame, rospy.Time.now(), list(env.finished),
                                                  list(env.task_correct), list(self._assigned), xy))

    def _refresh_markers(self) -> None:
        """Robot -> goal lines follow the robots while they drive."""
        while not rospy.is_shutdown():
            self._driving.wait(1.0)
            if self.pub_markers.get_num_connections() > 0:
                self.publish_markers(only_while_driving=True)
            rospy.rostime.wallsleep(self.marker_period)
