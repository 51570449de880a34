"""What the real executor hears from and sends to a fleet of real robots, besides goals: every
robot's odometry, scan and move_base status (to tell a silent one), how its scan fits the map
where localisation puts it (to tell a lost one), the ROS master's answers, and
the stop itself (every goal cancelled, zero cmd_vel, held for a moment; of every robot, or of one
robot alone), and the drive permits that open each robot's cmd_vel gate (apps/cmd_vel_gate_node.py). The decisions are the ROS-free
ros/safety.py's; this module only moves messages and runs the watchdog.
"""
from __future__ import annotations

import socket
import threading
import time
import xmlrpc.client
from typing import Callable, Dict, List, Optional, Sequence, Set, Tuple

import rosgraph
import rospy
import tf2_ros
from geometry_msgs.msg import Twist
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool, Float32

from marl_mrta.model.occupancy_map import OccupancyMap
from marl_mrta.model.scan_fit import TURN_WINDOW, ScanFit, quaternion_matrix, turn_rate
from marl_mrta.model.scenario import footprint_radius
from marl_mrta.ros.move_base_link import MoveBaseLink, TimeoutTransport
from marl_mrta.ros.safety import SafetyMonitor, hold_times

#: How often the watchdog asks the monitor, and the master is asked for its pid [wall s].
WATCH_PERIOD = 0.05
MASTER_PERIOD = 0.1
#: The zero command's period while a stop is held [wall s].
HOLD_PERIOD = 0.1
#: How long a scan waits for localisation's transform at its stamp (amcl's comes up to 0.5 s later).
SCAN_POSE_WAIT = rospy.Duration(0.5)


class FleetStop:
    """Stops every robot, or one robot alone (on_robot_fault continue, a robot that leaves): withdraws
    the drive permit (the robots' cmd_vel gates close), cancels all goals of its move_base and sends
    zero cmd_vel at once, then every HOLD_PERIOD for `hold` s (a command move_base had in flight
    cannot outlast it). The permit goes out on `~drive_permit` (the fleet's) and on
    `~drive_permit/<robot>` (the fleet's and that robot's own, which each robot's gate follows)."""

    def __init__(self, namespaces: Sequence[str], bases: Sequence[MoveBaseLink], hold: float):
        self.namespaces = list(namespaces)
        self.bases = list(bases)
        self.hold = hold
        # Made at start: a publisher made when the stop is due would still be connecting.
        self._cmd_vel = [rospy.Publisher("/" + ns + "/cmd_vel", Twist, queue_size=1, tcp_nodelay=True)
                         for ns in self.namespaces]
        # ~drive_permit: the node's own, sent by the watchdog 1 / WATCH_PERIOD times a second.
        self._permit = rospy.Publisher("~drive_permit", Bool, queue_size=1, tcp_nodelay=True)
        self._robot_permits = [rospy.Publisher("~drive_permit/" + ns, Bool, queue_size=1, tcp_nodelay=True)
                               for ns in self.namespaces]
        self._permit_lock = threading.Lock()
        self._withdrawn_at = float("-inf")
        self._withdrawn_robots: Set[int] = set()
        self._holding: Dict[int, threading.Event] = {i: threading.Event() for i in range(len(self.namespaces))}

    def robots_not_listening(self) -> List[str]:
        """Robots whose base (turtlebot3_core) does not subscribe to the manager's cmd_vel."""
        return [ns for ns, pub in zip(self.namespaces, self._cmd_vel) if pub.get_num_connections() == 0]

    def send_permit(self, allowed: bool, checked_at: float) -> None:
        """The permit as the monitor stood at `checked_at` (monotonic s); a yes checked before the
        last stop's withdrawal is stale and not sent. A robot stopped alone gets no yes."""
        with self._permit_lock:
            if allowed and checked_at <= self._withdrawn_at:
                return
            self._permit.publish(Bool(data=allowed))
            for i, pub in enumerate(self._robot_permits):
                pub.publish(Bool(data=allowed and i not in self._withdrawn_robots))

    def stop(self) -> None:
        with self._permit_lock:
            self._withdrawn_at = time.monotonic()
            self._permit.publish(Bool(data=False))
            for pub in self._robot_permits:
                pub.publish(Bool(data=False))
        for base in self.bases:
            base.cancel_all()
        self._stop_robots(range(len(self.namespaces)))

    def stop_robot(self, robot: int) -> None:
        """That robot alone: its permit withdrawn until grant_robot(), its goals cancelled, zero held."""
        with self._permit_lock:
            self._withdrawn_robots.add(robot)
            self._robot_permits[robot].publish(Bool(data=False))
        self.bases[robot].cancel_all()
        self._stop_robots([robot])

    def grant_robot(self, robot: Optional[int] = None) -> None:
        """The robot (None: every robot) may drive again once the fleet may (it joined, a new episode)."""
        with self._permit_lock:
            if robot is None:
                self._withdrawn_robots.clear()
            else:
                self._withdrawn_robots.discard(robot)

    def wait_hold(self, timeout: float) -> None:
        """Returns once every held stop has sent its last zero command (at most `timeout` s)."""
        deadline = time.monotonic() + timeout
        while any(e.is_set() for e in self._holding.values()) and time.monotonic() < deadline:
            time.sleep(0.01)

    def _stop_robots(self, robots) -> None:
        robots = list(robots)
        for i in robots:
            self._cmd_vel[i].publish(Twist())
        if self.hold <= 0.0:
            return
        for i in robots:
            if not self._holding[i].is_set():
                self._holding[i].set()
                threading.Thread(target=self._hold, args=(i,), daemon=True, name=f"stop_hold_{i}").start()

    def _hold(self, robot: int) -> None:
        start = time.monotonic()
        for due in hold_times(start, self.hold, HOLD_PERIOD)[1:]:
            time.sleep(max(0.0, due - time.monotonic()))
            self._cmd_vel[robot].publish(Twist())
        self._holding[robot].clear()


class FleetWatch:
    """Feeds a SafetyMonitor from the graph, calls `on_robot_fault(robot, reason)` for each robot
    with a fault of its own and `on_fault(reason)` for a fault of the fleet, while the fleet is not
    stopped already, and `permit(may_drive, checked_at)` at every check. With `scan_fit`, every
    scan also goes to its on_scan() once heard."""

    def __init__(self, namespaces: Sequence[str], monitor: SafetyMonitor, on_fault: Callable[[str], None],
                 permit: Callable[[bool, float], None], scan_fit: Optional["ScanFitWatch"] = None,
                 on_robot_fault: Optional[Callable[[int, str], None]] = None):
        self.monitor = monitor
        self.on_fault = on_fault
        self.on_robot_fault = on_robot_fault or (lambda robot, reason: on_fault(reason))
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
        master = xmlrpc.client.ServerProxy(self._master_uri, transport=TimeoutTransport(timeout))
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
                now = time.monotonic()
                for robot, reason in self.monitor.robot_faults(now):
                    self.on_robot_fault(robot, reason)   # stops it alone, or the fleet (and trips)
                    if self.monitor.tripped:
                        break
                reason = "" if self.monitor.tripped else self.monitor.fleet_fault(now)
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
