"""What the real executor hears from and sends to a fleet of real robots, besides goals: every
robot's odometry, scan and move_base status (to tell a silent one), how its scan fits the map
where localisation puts it (to tell a lost one), the ROS master's answers, and
the stop itself (every goal cancelled, zero cmd_vel, held for a moment), and the drive permit
that opens each robot's cmd_vel gate (apps/cmd_vel_gate_node.py). The decisions are the ROS-free
ros/safety.py's; this module only moves messages and runs the watchdog.
"""
from __future__ import annotations

import socket
import threading
import time
import xmlrpc.client
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import rosgraph
import rospy
import tf2_ros
from geometry_msgs.msg import Twist
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool, Float32

from marl_mrta.model.occupancy_map import OccupancyMap
from marl_mrta.model.scan_fit import TURN_WINDOW, ScanFit, quaternion_matrix, turn_rate
from marl_mrta.model.scenario import footprint_radius
from marl_mrta.ros.move_base_link import MoveBaseLink
from marl_mrta.ros.safety import SafetyMonitor, hold_times

#: How often the watchdog asks the monitor, and the master is asked for its pid [wall s].
WATCH_PERIOD = 0.05
MASTER_PERIOD = 0.1
#: The zero command's period while a stop is held [wall s].
HOLD_PERIOD = 0.1
#: How long a scan waits for localisation's transform at its stamp (amcl's comes up to 0.5 s later).
SCAN_POSE_WAIT = rospy.Duration(0.5)


class _TimeoutTransport(xmlrpc.client.Transport):
    """An XML-RPC transport whose connections give up after `timeout` s (rosgraph's have none)."""

    def __init__(self, timeout: float):
        super().__init__()
        self.timeout = timeout

    def make_connection(self, host):
        connection = super().make_connection(host)
        connection.timeout = self.timeout
        return connection


class FleetStop:
    """Stops every robot: withdraws the drive permit (the robots' cmd_vel gates close), cancels
    all goals of its move_base and sends zero cmd_vel at once, then every HOLD_PERIOD for `hold`
    s (a command move_base had in flight cannot outlast it)."""

    def __init__(self, namespaces: Sequence[str], bases: Sequence[MoveBaseLink], hold: float):
        self.namespaces = list(namespaces)
        self.bases = list(bases)
        self.hold = hold
        # Made at start: a publisher made when the stop is due would still be connecting.
        self._cmd_vel = [rospy.Publisher("/" + ns + "/cmd_vel", Twist, queue_size=1, tcp_nodelay=True)
                         for ns in self.namespaces]
        # ~drive_permit: the node's own, sent by the watchdog 1 / WATCH_PERIOD times a second.
        self._permit = rospy.Publisher("~drive_permit", Bool, queue_size=1, tcp_nodelay=True)
        self._permit_lock = threading.Lock()
        self._withdrawn_at = float("-inf")
        self._holding = threading.Event()

    def robots_not_listening(self) -> List[str]:
        """Robots whose base (turtlebot3_core) does not subscribe to the manager's cmd_vel."""
        return [ns for ns, pub in zip(self.namespaces, self._cmd_vel) if pub.get_num_connections() == 0]

    def send_permit(self, allowed: bool, checked_at: float) -> None:
        """The permit as the monitor stood at `checked_at` (monotonic s); a yes checked before the
        last stop's withdrawal is stale and not sent."""
        with self._permit_lock:
            if allowed and checked_at <= self._withdrawn_at:
                return
            self._permit.publish(Bool(data=allowed))

    def stop(self) -> None:
        with self._permit_lock:
            self._withdrawn_at = time.monotonic()
            self._permit.publish(Bool(data=False))
        for base in self.bases:
            base.cancel_all()
        self._send_zero()
        if self.hold > 0.0 and not self._holding.is_set():
            self._holding.set()
            threading.Thread(target=self._hold, daemon=True, name="stop_hold").start()

    def wait_hold(self, timeout: float) -> None:
        """Returns once a held stop has sent its last zero command (at most `timeout` s)."""
        deadline = time.monotonic() + timeout
        while self._holding.is_set() and time.monotonic() < deadline:
            time.sleep(0.01)

    def _send_zero(self) -> None:
        for pub in self._cmd_vel:
            pub.publish(Twist())

    def _hold(self) -> None:
        start = time.monotonic()
        for due in hold_times(start, self.hold, HOLD_PERIOD)[1:]:
            time.sleep(max(0.0, due - time.monotonic()))
            self._send_zero()
        self._holding.clear()


class FleetWatch:
    """Feeds a SafetyMonitor from the graph, calls `on_fault(reason)` when it finds a fault
    while the fleet is not stopped already, and `permit(may_drive, checked_at)` at every check.
    With `scan_fit`, every scan also goes to its on_scan() once heard."""

    def __init__(self, namespaces: Sequence[str], monitor: SafetyMonitor, on_fault: Callable[[str], None],
                 permit: Callable[[bool, float], None], scan_fit: Optional["ScanFitWatch"] = None):
        self.monitor = monitor
        self.on_fault = on_fault
        self.permit = permit
        self.scan_fit = scan_fit
        for i, ns in enumerate(namespaces):
            for part, topic in (("odom", "odom"), ("scan", "scan"), ("move_base", "move_base/status")):
                # AnyMsg: only the arrival counts, nothing is deserialised. One process has one
                # type per topic, so the scan fit reads the scan of this subscription.
                kind = LaserScan if part == "scan" and scan_fit is not None else rospy.AnyMsg
                rospy.Subscriber("/" + ns + "/" + topic, kind, self._on_message, (i, part), queue_size=1,
                                 tcp_nodelay=True)
        self._master_uri = rosgraph.get_master_uri()
        threading.Thread(target=self._watch_master, daemon=True, name="master_watch").start()
        threading.Thread(target=self._watch, daemon=True, name="fleet_watch").start()

    def _on_message(self, msg, robot_part) -> None:
        self.monitor.heard(robot_part[0], robot_part[1], time.monotonic())
        if robot_part[1] == "scan" and self.scan_fit is not None:
            self.scan_fit.on_scan(msg, robot_part[0])

    def _watch_master(self) -> None:
        timeout = max(0.05, min(0.5, self.monitor.limits.master_lost_after / 2.0))
        master = xmlrpc.client.ServerProxy(self._master_uri, transport=_TimeoutTransport(timeout))
        while not rospy.core.is_shutdown():
            try:
                master.getPid(rospy.get_name())
                self.monitor.master_answered(time.monotonic())
            except (OSError, socket.timeout, xmlrpc.client.Error) as error:
                self.monitor.master_failed(f"{self._master_uri}: {error}")
            time.sleep(MASTER_PERIOD)

    def _watch(self) -> None:
        while not rospy.core.is_shutdown():
            if not self.monitor.tripped:
                reason = self.monitor.fault(time.monotonic())
                if reason:
                    self.on_fault(reason)
            checked_at = time.monotonic()
            self.permit(not self.monitor.tripped, checked_at)
            time.sleep(WATCH_PERIOD)


class ScanFitWatch:
    """Places each robot's scan (FleetWatch hands it over) on the map where localisation puts the
    laser at the scan's stamp (tf: map -> the scan's frame), leaving out the other robots where
    their latest scans were taken, and skipping scans taken while the robot turns faster than
    scan_fit_max_turn; reports the fit to the monitor, and publishes it on the robot's
    `scan_fit` (std_msgs/Float32, 0..1) for the operator. A scan whose transform does not come
    within SCAN_POSE_WAIT is skipped: a localisation node that stops publishing shows as
    move_base's failure, not here."""

    def __init__(self, namespaces: Sequence[str], occupancy_map: OccupancyMap, tf_buffer: tf2_ros.Buffer,
                 map_frame: str, monitor: SafetyMonitor):
        self.monitor = monitor
        self.tf = tf_buffer
        self.map_frame = map_frame
        self.scan_fit = ScanFit(occupancy_map, monitor.limits.scan_fit_tolerance, footprint_radius())
        self._lasers: Dict[int, Tuple[float, float]] = {}   # robot -> where its latest scan was taken (map)
        self._lock = threading.Lock()   # scans of different robots arrive on threads of their own
        self._published = [rospy.Publisher("/" + ns + "/scan_fit", Float32, queue_size=1) for ns in namespaces]

    def on_scan(self, scan: LaserScan, robot: int) -> None:
        try:
            placed = self.tf.lookup_transform(self.map_frame, scan.header.frame_id, scan.header.stamp,
                                              SCAN_POSE_WAIT).transform
            before = self.tf.lookup_transform(self.map_frame, scan.header.frame_id,
                                              scan.header.stamp - rospy.Duration(TURN_WINDOW)).transform.rotation
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException,
                tf2_ros.InvalidArgumentException):
            return
        q, t = placed.rotation, placed.translation
        rotation = quaternion_matrix(q.x, q.y, q.z, q.w)
        with self._lock:
            self._lasers[robot] = (t.x, t.y)   # a Burger's laser sits 3 cm from its centre
            others = [xy for other, xy in self._lasers.items() if other != robot]
        turning = turn_rate(quaternion_matrix(before.x, before.y, before.z, before.w), rotation,
                            TURN_WINDOW) > self.monitor.limits.scan_fit_max_turn
        fit = None if turning else self.scan_fit.fit(scan.ranges, scan.angle_min, scan.angle_increment,
                                                     scan.range_min, scan.range_max, rotation, (t.x, t.y, t.z), others)
        self.monitor.fitted(robot, fit, time.monotonic())
        if fit is not None:
            self._published[robot].publish(Float32(fit))
