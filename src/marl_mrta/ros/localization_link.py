"""One robot's localisation as the task manager re-initialises it on every reset in simulation:
`initialpose` out (the pose the robot was reset to), `amcl_pose` in (stock amcl or the built-in
particle filter, both publish it). The executor waits until every robot's estimate agrees with
its reset pose before it sends the first goal, so that no episode starts on a lost robot."""
from __future__ import annotations

import math
import threading
from typing import Optional, Tuple

import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped
from std_srvs.srv import Empty

from marl_mrta.ros.move_base_link import yaw_to_quaternion
from marl_mrta.ros.sim_link import quaternion_to_yaw

#: Standard deviations of the initial pose sent after a reset [m, m, rad]: the simulator has just
#: put the robot there, so the filter starts narrow (amcl's own default is 0.5 m / 0.26 rad).
RESET_SIGMA = (0.02, 0.02, 0.02)


class LocalizationLink:
    def __init__(self, namespace: str, map_frame: str):
        self.namespace = namespace
        self.map_frame = map_frame
        self._lock = threading.Lock()
        self._latest: Optional[Tuple[float, float, float, float]] = None   # stamp, x, y, yaw
        self._since = math.inf
        self._asking = False   # a request_nomotion_update call is under way
        self._publisher = rospy.Publisher(namespace + "/initialpose", PoseWithCovarianceStamped, queue_size=1,
                                          latch=True)
        rospy.Subscriber(namespace + "/amcl_pose", PoseWithCovarianceStamped, self._on_pose, queue_size=5)
        self._nomotion = rospy.ServiceProxy(namespace + "/request_nomotion_update", Empty)

    def connected(self) -> bool:
        """The localisation node listens to initialpose."""
        return self._publisher.get_num_connections() > 0

    def reinitialise(self, pose: Tuple[float, float, float]) -> None:
        """Sends `pose` as the robot's initial pose; only estimates stamped from now count."""
        now = rospy.Time.now()
        msg = PoseWithCovarianceStamped()
        msg.header.stamp, msg.header.frame_id = now, self.map_frame
        msg.pose.pose.position.x, msg.pose.pose.position.y = pose[0], pose[1]
        o = msg.pose.pose.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(pose[2])
        covariance = [0.0] * 36
        covariance[0], covariance[7], covariance[35] = RESET_SIGMA[0] ** 2, RESET_SIGMA[1] ** 2, RESET_SIGMA[2] ** 2
        msg.pose.covariance = covariance
        with self._lock:
            self._since = now.to_sec()
        self._publisher.publish(msg)

    def request_update(self) -> None:
        """Asks amcl to take its next scan even though the robot has not moved (it updates only
        after motion, and the scan it took first after the initial pose may predate the reset).
        In the background, one call at a time: stock amcl's initial-pose handler waits for a
        transform on sim time on the thread that also answers this service, so a call that
        blocked here while the simulator stands would never be answered."""
        with self._lock:
            if self._asking:
                return
            self._asking = True
        threading.Thread(target=self._ask_for_update, name=self.namespace + "/nomotion", daemon=True).start()

    def _ask_for_update(self) -> None:
        try:
            self._nomotion()
        except (rospy.ServiceException, rospy.ROSException):
            pass   # not there (yet) or shutting down: the executor asks again, and waits for amcl_pose
        finally:
            with self._lock:
                self._asking = False

    def error_to(self, pose: Tuple[float, float, float]) -> Optional[Tuple[float, float]]:
        """Distance [m] and heading difference [rad] between the latest estimate since the last
        reinitialise() and `pose`; None while there is none."""
        with self._lock:
            latest, since = self._latest, self._since
        if latest is None or latest[0] < since - 1e-9:
            return None
        _, x, y, yaw = latest
        return math.hypot(x - pose[0], y - pose[1]), abs((yaw - pose[2] + math.pi) % (2.0 * math.pi) - math.pi)

    def pose(self) -> Optional[Tuple[float, float, float, float]]:
        """The latest estimate (stamp, x, y, yaw), whenever it came; None before the first."""
        with self._lock:
            return self._latest

    def _on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        p = msg.pose.pose
        with self._lock:
            self._latest = (msg.header.stamp.to_sec(), p.position.x, p.position.y, quaternion_to_yaw(p.orientation))
