"""cmd_vel_gate: lets a real robot's navigation drive it only while the task manager permits it.

Started in the robot's namespace by launch/include/real_robot.launch, where move_base publishes
on cmd_vel_nav instead of cmd_vel. Relays cmd_vel_nav to cmd_vel while the gate is open
(ros/safety.py, VelocityGate): while the task manager's drive permit (~permit_topic, std_msgs/Bool,
sent 20 times a second) says yes and is at most ~permit_timeout wall seconds old. When the gate
closes (a stop, or the manager gone) it cancels every goal of this robot's move_base, sends zero
cmd_vel, and from then on a zero command in place of each navigation command, and logs why.
Why: stock move_base reads a cancel only between recovery behaviours, and its rotate_recovery
keeps publishing its turn for up to about 7 s; a manager that crashed stops nothing at all.
Publishes ~state (std_msgs/String, latched): "open", or "closed: " and why. Parameters:
~permit_topic (default /rl_task_allocation_manager/drive_permit), ~permit_timeout (default 1.0 s),
~check_rate (default 20 Hz).
"""
import threading
import time

import rospy
from actionlib_msgs.msg import GoalID
from geometry_msgs.msg import Twist
from std_msgs.msg import Bool, String

from marl_mrta.common.config import ConfigError, node_parameters
from marl_mrta.ros.safety import VelocityGate


class CmdVelGateNode:
    def __init__(self, gate: VelocityGate, permit_topic: str, check_rate: float):
        self.gate = gate
        self._lock = threading.Lock()
        self._cmd_vel = rospy.Publisher("cmd_vel", Twist, queue_size=1, tcp_nodelay=True)
        self._cancel = rospy.Publisher("move_base/cancel", GoalID, queue_size=1, tcp_nodelay=True)
        # What an operator asks when a robot does not move: `rostopic echo NS/cmd_vel_gate/state`.
        self._state = rospy.Publisher("~state", String, queue_size=1, latch=True)
        self._state.publish(String(data="closed: " + gate.reason))
        rospy.Subscriber(permit_topic, Bool, self._on_permit, queue_size=1, tcp_nodelay=True)
        rospy.Subscriber("cmd_vel_nav", Twist, self._on_command, queue_size=1, tcp_nodelay=True)
        self._period = 1.0 / check_rate

    def _on_permit(self, msg: Bool) -> None:
        with self._lock:
            self.gate.permit(msg.data, time.monotonic())
            self._check()

    def _on_command(self, msg: Twist) -> None:
        # Under the lock: a command let through cannot follow the zero of a closing.
        with self._lock:
            self._cmd_vel.publish(msg if self._check() else Twist())

    def _check(self) -> bool:
        """Whether the gate is open; on closing cancels every goal and sends zero. Callers hold the lock."""
        is_open, change = self.gate.update(time.monotonic())
        if change and not is_open:
            self._cancel.publish(GoalID())   # an empty id cancels every goal (actionlib)
            self._cmd_vel.publish(Twist())
            # A withdrawn permit is the manager's stop, whose reason it logs itself (at ERROR if a
            # fault); a permit that stopped coming is known here alone.
            log = rospy.loginfo if self.gate.permit_withdrawn else rospy.logerr
            log("%s: gate closed: %s: every move_base goal cancelled, zero cmd_vel", rospy.get_name(), change)
            self._state.publish(String(data="closed: " + change))
        elif change:
            rospy.loginfo("%s: gate open: move_base drives the robot", rospy.get_name())
            self._state.publish(String(data="open"))
        return is_open

    def shut_down(self) -> None:
        """The gate's last word: a robot never keeps the gate's last relayed command."""
        with self._lock:
            self._cmd_vel.publish(Twist())

    def spin(self) -> None:
        # Checked on wall time: a silent manager sends nothing that would trigger a check.
        while not rospy.is_shutdown():
            with self._lock:
                self._check()
            time.sleep(self._period)


def main() -> int:
    rospy.init_node("cmd_vel_gate")
    try:
        own = node_parameters(rospy.get_param("~", {}), rospy.get_name())
        permit_topic = own.string("permit_topic", "/rl_task_allocation_manager/drive_permit", allow_empty=False)
        gate = VelocityGate(own.number("permit_timeout", 1.0, above=0.0))
        check_rate = own.number("check_rate", 20.0, above=0.0)
        own.check_all_used()
    except ConfigError as error:
        rospy.logfatal("%s", error)
        return 2
    node = CmdVelGateNode(gate, permit_topic, check_rate)
    rospy.on_shutdown(node.shut_down)
    rospy.loginfo("%s: closed until %s permits driving", rospy.get_name(), permit_topic)
    node.spin()
    return 0
