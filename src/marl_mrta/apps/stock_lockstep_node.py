"""stock_lockstep: answers the simulator's lock-step ticks for one robot's stock move_base.

Started in the robot's namespace by launch/include/robot_nav.launch with nav:=stock and
lockstep:=true. The rule (ros/stock_lockstep.py): on a control tick of an active goal the
simulator waits for the robot's cmd_vel (at most ~command_wait wall seconds); between control
ticks it runs on, and without a goal after ~idle_wait. With ~wait_for_amcl (localization:=amcl)
every answer also waits for amcl's map -> odom of the latest scan. Parameters (wall seconds):
~command_wait (default 0.5), ~result_wait (0.05), ~idle_wait (0.005); ~wait_for_amcl (false).
move_base's controller_frequency, amcl's transform_tolerance and the simulator's physics_rate
are read from their nodes. Subscribes to cmd_vel, move_base/goal, move_base/result and
/simulator/tick, move_base's global plans (and /tf with amcl); publishes /simulator/lockstep_ack.
"""
import threading
import time

import rospy
from geometry_msgs.msg import Twist
from actionlib_msgs.msg import GoalStatusArray
from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult
from nav_msgs.msg import Path
from tf2_msgs.msg import TFMessage

from marl_mrta.common.config import ConfigError, node_parameters
from marl_mrta.msg import LockstepAck, SimTick
from marl_mrta.ros.stock_lockstep import StockLockstepRule

SIMULATOR = "/simulator"


class StockLockstepNode:
    def __init__(self, robot: str, rule: StockLockstepRule):
        self.robot = robot
        self.rule = rule
        self._changed = threading.Condition()
        self._ack_pub = rospy.Publisher(SIMULATOR + "/lockstep_ack", LockstepAck, queue_size=100)
        rospy.Subscriber("cmd_vel", Twist, self._on_command, queue_size=100, tcp_nodelay=True)
        rospy.Subscriber("move_base/goal", MoveBaseActionGoal, self._on_goal, queue_size=10, tcp_nodelay=True)
        rospy.Subscriber("move_base/result", MoveBaseActionResult, self._on_result, queue_size=10, tcp_nodelay=True)
        # The global planner's plans, "move_base/<plugin>/plan" (navfn/NavfnROS: move_base/NavfnROS/plan).
        planner = str(rospy.get_param("move_base/base_global_planner", "navfn/NavfnROS")).split("/")[-1]
        rospy.Subscriber("move_base/%s/plan" % planner, Path, self._on_plan, queue_size=10, tcp_nodelay=True)
        self._status_sub = rospy.Subscriber("move_base/status", GoalStatusArray, lambda _msg: None, queue_size=1)
        self._up = False
        if rule.localization_tolerance > 0.0:   # stock amcl: its map -> odom is waited for
            self._filter_frames = (rospy.get_param("amcl/global_frame_id", "map"),
                                   rospy.get_param("amcl/odom_frame_id", robot + "/odom"))
            rospy.Subscriber("/tf", TFMessage, self._on_tf, queue_size=100, tcp_nodelay=True)

    def start(self) -> None:
        # An ack sent before the simulator listens would be lost.
        while self._ack_pub.get_num_connections() == 0 and not rospy.is_shutdown():
            time.sleep(0.05)
        rospy.Subscriber(SIMULATOR + "/tick", SimTick, self._on_tick, queue_size=10, tcp_nodelay=True)

    def _move_base_up(self) -> bool:
        """move_base's action server starts last, once its costmaps are made; they wait for
        transforms on sim time, so until then the ticks are answered at real-time pace."""
        if not self._up and self._status_sub.get_num_connections() > 0:
            self._up = True
            self._status_sub.unregister()
            rospy.loginfo("%s: move_base is up: lock-step from sim time %.2f s", rospy.get_name(), rospy.get_time())
        return self._up

    def _on_command(self, msg: Twist) -> None:
        with self._changed:
            self.rule.on_command(msg.linear.x == 0.0 and msg.angular.z == 0.0, rospy.get_time())
            self._changed.notify_all()

    def _on_plan(self, msg: Path) -> None:
        with self._changed:
            self.rule.on_plan(not msg.poses)
            self._changed.notify_all()

    def _on_tf(self, msg: TFMessage) -> None:
        for transform in msg.transforms:
            if (transform.header.frame_id, transform.child_frame_id) == self._filter_frames:
                with self._changed:
                    self.rule.on_localization(transform.header.stamp.to_sec())
                    self._changed.notify_all()

    def _on_goal(self, _msg: MoveBaseActionGoal) -> None:
        with self._changed:
            rospy.logdebug("goal at sim time %.2f s", rospy.get_time())
            self.rule.on_goal()
            self._changed.notify_all()

    def _on_result(self, msg: MoveBaseActionResult) -> None:
        with self._changed:
            rospy.logdebug("result %d stamped %.2f s, at sim time %.2f s", msg.status.status, msg.header.stamp.to_sec(), rospy.get_time())
            self.rule.on_result(msg.header.stamp.to_sec())
            self._changed.notify_all()

    def _on_tick(self, msg: SimTick) -> None:
        if not self._move_base_up():
            time.sleep(self.rule.tick_period)
            self._publish(LockstepAck(robot=self.robot, tick=msg.tick, cmd_vel_count=self.rule.commands))
            return
        with self._changed:
            timeouts = self.rule.timeouts
            self.rule.on_tick(msg.tick, msg.stamp.to_sec(), time.monotonic(), msg.last_scan_stamp.to_sec())
            answer = self.rule.answer(time.monotonic())
            while answer is None and not rospy.is_shutdown():
                self._changed.wait(self.rule.wait_left(time.monotonic()) + 1e-3)
                answer = self.rule.answer(time.monotonic())
            if self.rule.timeouts > timeouts:
                rospy.logdebug("tick %d: no cmd_vel from move_base within %.2f s; answered without one",
                               msg.tick, self.rule.command_wait)
        if answer is not None:
            self._publish(LockstepAck(robot=self.robot, tick=answer.tick, cmd_vel_count=answer.cmd_vel_count,
                                      next_stamp=rospy.Time.from_sec(answer.next_stamp),
                                      goal_end_tick=answer.goal_end_tick))

    def _publish(self, ack: LockstepAck) -> None:
        try:
            self._ack_pub.publish(ack)
        except rospy.ROSException:
            pass   # the node is going down: rospy closes its topics before is_shutdown() says so


def read_rule() -> StockLockstepRule:
    """The rule from this node's parameters and those of move_base, amcl and the simulator (the
    defaults are those nodes' own); a bad value raises ConfigError naming it."""
    own = node_parameters(rospy.get_param("~", {}), rospy.get_name())
    move_base = node_parameters(rospy.get_param("move_base", {}), rospy.resolve_name("move_base"))
    simulator = node_parameters(rospy.get_param(SIMULATOR, {}), SIMULATOR)
    amcl = node_parameters(rospy.get_param("amcl", {}), rospy.resolve_name("amcl"))
    wait_for_amcl = own.boolean("wait_for_amcl", False)
    rule = StockLockstepRule(1.0 / move_base.number("controller_frequency", 20.0, above=0.0),
                             simulator.number("physics_rate", 20.0, above=0.0),
                             own.number("command_wait", 0.5, minimum=0.0), own.number("result_wait", 0.05, minimum=0.0),
                             own.number("idle_wait", 0.005, minimum=0.0),
                             amcl.number("transform_tolerance", 0.1, above=0.0) if wait_for_amcl else 0.0)
    own.check_all_used()
    return rule


def main() -> int:
    rospy.init_node("stock_lockstep")
    robot = rospy.get_namespace().strip("/")
    try:
        rule = read_rule()
    except ConfigError as error:
        rospy.logfatal("%s", error)
        return 2
    node = StockLockstepNode(robot, rule)
    rospy.loginfo("%s: answering lock-step ticks for %s's stock move_base (control period %.3f s, command wait %.2f s)",
                  rospy.get_name(), robot, rule.control_period, rule.command_wait)
    node.start()
    rospy.spin()
    if rule.timeouts:
        rospy.loginfo("%s: %d control ticks answered without a cmd_vel", rospy.get_name(), rule.timeouts)
    if rule.quiet_ticks:
        rospy.loginfo("%s: %d ticks answered at once while move_base had no path to its goal", rospy.get_name(),
                      rule.quiet_ticks)
    return 0
