"""One robot's move_base, spoken to over the actionlib wire protocol (MoveBaseAction topics).

The topics `goal`, `cancel`, `status` and `result` under `<ns>/move_base` are used directly
rather than through actionlib's SimpleActionClient because the executor needs the sim time at
which move_base finished a goal (the result's header stamp), not the later moment at which this
node happened to process the result. Works with the stock and the built-in move_base alike.
"""
from __future__ import annotations

import itertools
import math
import socket
import threading
import time
import xmlrpc.client
from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence

import rosgraph
import rospy
from actionlib_msgs.msg import GoalID, GoalStatus, GoalStatusArray
from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult

from marl_mrta.ros.sim_clock import wait_wall

_TERMINAL = {GoalStatus.PREEMPTED, GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.REJECTED,
             GoalStatus.RECALLED, GoalStatus.LOST}
_STATE_NAMES = {v: k for k, v in vars(GoalStatus).items() if k.isupper() and isinstance(v, int)}
_ids = itertools.count()


def yaw_to_quaternion(yaw: float):
    return 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)


@dataclass(frozen=True)
class GoalResult:
    state: int          # actionlib_msgs/GoalStatus value
    text: str           # move_base's status text, e.g. "Goal reached." or why it aborted
    stamp: float        # sim time at which move_base finished the goal

    @property
    def succeeded(self) -> bool:
        return self.state == GoalStatus.SUCCEEDED

    def describe(self) -> str:
        name = _STATE_NAMES.get(self.state, str(self.state))
        return f"move_base {name.lower()}" + (f": {self.text}" if self.text else "")


class TimeoutTransport(xmlrpc.client.Transport):
    """An XML-RPC transport whose connections give up after `timeout` s (rosgraph's have none)."""

    def __init__(self, timeout: float):
        super().__init__()
        self.timeout = timeout

    def make_connection(self, host):
        connection = super().make_connection(host)
        connection.timeout = self.timeout
        return connection


def node_gone(name: str, timeout_wall: float = 1.0) -> bool:
    """Whether a node's process is gone: the master knows no such node, or nothing listens on its
    XML-RPC port any more (a killed process's connection is refused). A node that is merely slow to
    answer, and an unreachable master, do not count: that is not this node's fault."""
    caller = rospy.get_name()
    try:
        uri = rosgraph.Master(caller).lookupNode(name)
    except (rosgraph.masterapi.Error, rosgraph.masterapi.Failure):
        return True
    except (OSError, xmlrpc.client.Error):
        return False
    try:
        xmlrpc.client.ServerProxy(uri, transport=TimeoutTransport(timeout_wall)).getPid(caller)
    except ConnectionRefusedError:
        return True
    except (OSError, socket.timeout, xmlrpc.client.Error):
        return False
    return False


class MoveBaseLink:
    """Sends one goal at a time to `<namespace>/move_base` and records how it ended."""

    def __init__(self, namespace: str, frame_id: str):
        self.namespace = namespace
        self.frame_id = frame_id
        self.goal_id: Optional[str] = None
        self.accepted = False
        self.result: Optional[GoalResult] = None
        self._status_seen = False
        self._lock = threading.Lock()
        base = namespace + "/move_base"
        self._goal_pub = rospy.Publisher(base + "/goal", MoveBaseActionGoal, queue_size=10)
        self._cancel_pub = rospy.Publisher(base + "/cancel", GoalID, queue_size=10)
        rospy.Subscriber(base + "/status", GoalStatusArray, self._on_status, queue_size=10)
        rospy.Subscriber(base + "/result", MoveBaseActionResult, self._on_result, queue_size=10)

    @property
    def server_name(self) -> str:
        return self.namespace + "/move_base"

    def connected(self) -> bool:
        """move_base listens to goals and cancels and has published its status."""
        return (self._status_seen and self._goal_pub.get_num_connections() > 0
                and self._cancel_pub.get_num_connections() > 0)

    def send(self, x: float, y: float, yaw: float) -> None:
        goal = MoveBaseActionGoal()
        now = rospy.Time.now()
        goal_id = f"{rospy.get_name()}/{self.namespace}/{next(_ids)}-{time.time_ns()}"
        goal.header.stamp = now
        goal.goal_id.id, goal.goal_id.stamp = goal_id, now
        target = goal.goal.target_pose
        target.header.frame_id, target.header.stamp = self.frame_id, now
        target.pose.position.x, target.pose.position.y = x, y
        o = target.pose.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(yaw)
        with self._lock:
            self.goal_id, self.accepted, self.result = goal_id, False, None
        self._goal_pub.publish(goal)

    def cancel(self) -> None:
        """Cancels the current goal if it is still running."""
        with self._lock:
            goal_id = self.goal_id if self.result is None else None
        if goal_id is not None:
            self._cancel_pub.publish(GoalID(id=goal_id))

    def cancel_all(self) -> None:
        """Cancels every goal of this move_base, whoever sent it (an empty id: actionlib's
        cancel-all), e.g. to stop the robot whatever it was told."""
        self._cancel_pub.publish(GoalID())

    def process_gone(self) -> bool:
        """The move_base node's process is gone (node_gone; the node is `<namespace>/move_base`)."""
        return node_gone(self.server_name)

    def forget(self) -> None:
        with self._lock:
            self.goal_id, self.accepted, self.result = None, False, None

    @property
    def idle(self) -> bool:
        """No goal, or the goal has ended."""
        with self._lock:
            return self.goal_id is None or self.result is not None

    def _on_status(self, msg: GoalStatusArray) -> None:
        with self._lock:
            self._status_seen = True
            for status in msg.status_list:
                if status.goal_id.id == self.goal_id and status.status != GoalStatus.PENDING:
                    self.accepted = True

    def _on_result(self, msg: MoveBaseActionResult) -> None:
        with self._lock:
            if msg.status.goal_id.id != self.goal_id or self.result is not None:
                return
            self.accepted = True
            self.result = GoalResult(msg.status.status, msg.status.text, msg.header.stamp.to_sec())


def send_goals(bases: Sequence["MoveBaseLink"], tasks, goals: Sequence[Optional[int]]) -> List[int]:
    """Sends robot i the goal pose of task goals[i] (None: no goal); returns the robots given one."""
    pending = [i for i, g in enumerate(goals) if g is not None]
    for i in pending:
        goal = tasks[goals[i]].goal
        bases[i].send(goal.x, goal.y, goal.yaw)
    return pending


def await_accepted(bases: Sequence["MoveBaseLink"], robots: Sequence[int], timeout_wall: float,
                   stop: Callable[[], bool] = lambda: False) -> None:
    """Waits until the move_base of every robot in `robots` took its goal (or `stop()`); raises
    SimulatorLost naming those that did not within `timeout_wall` s."""
    wait_wall(lambda: stop() or all(bases[i].accepted for i in robots), timeout_wall,
              lambda: "move_base of " + ", ".join(bases[i].namespace.lstrip("/") for i in robots
                                                  if not bases[i].accepted) + " did not take its goal")


def cancel_running(bases: Sequence["MoveBaseLink"], timeout_wall: float) -> None:
    """Cancels every goal still running and waits until its move_base has stopped it (its result
    came); raises SimulatorLost after `timeout_wall` s."""
    running = [base for base in bases if not base.idle]
    for base in running:
        base.cancel()
    wait_wall(lambda: all(base.idle for base in running), timeout_wall,
              lambda: "move_base of " + ", ".join(base.namespace.lstrip("/") for base in running if not base.idle)
              + " did not confirm a cancelled goal")
