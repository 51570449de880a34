"""What the sim-to-real report measures in a running graph, per robot: the commands on cmd_vel
(when they arrive, on the graph's clock: wall time with robots, sim time in the simulation), the
odometry (stamped), when scans arrive, amcl's estimates and, in the simulation only, the ground truth. The figures
are computed afterwards, without ROS (evaluation/sim_to_real.py)."""
from __future__ import annotations

import argparse
import threading
from pathlib import Path
from typing import Dict, List, Sequence

import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import Odometry

from marl_mrta.common.results import write_result
from marl_mrta.ros.sim_link import quaternion_to_yaw


class GraphProbe:
    def __init__(self, robots: Sequence[str]):
        self.lock = threading.Lock()
        self.records: Dict[str, Dict[str, List[list]]] = {
            ns: {"cmd_vel": [], "odom": [], "scan": [], "amcl_pose": [], "ground_truth": []} for ns in robots}
        for ns in robots:
            rospy.Subscriber("/%s/cmd_vel" % ns, Twist, self._on_command, ns, queue_size=100, tcp_nodelay=True)
            rospy.Subscriber("/%s/odom" % ns, Odometry, self._on_odom, (ns, "odom"), queue_size=100, tcp_nodelay=True)
            # Only when each scan arrives (a silent robot's last one): nothing is deserialised.
            rospy.Subscriber("/%s/scan" % ns, rospy.AnyMsg, self._on_arrival, (ns, "scan"), queue_size=10)
            rospy.Subscriber("/%s/base_pose_ground_truth" % ns, Odometry, self._on_pose_odom, (ns, "ground_truth"),
                             queue_size=100)
            rospy.Subscriber("/%s/amcl_pose" % ns, PoseWithCovarianceStamped, self._on_amcl, ns, queue_size=50)

    def _add(self, ns: str, kind: str, row: list) -> None:
        with self.lock:
            self.records[ns][kind].append(row)

    def _on_command(self, msg: Twist, ns: str) -> None:
        self._add(ns, "cmd_vel", [rospy.get_time(), msg.linear.x, msg.angular.z])

    def _on_arrival(self, _msg, key) -> None:
        self._add(key[0], key[1], [rospy.get_time()])

    def _on_odom(self, msg: Odometry, key) -> None:
        twist = msg.twist.twist
        self._add(key[0], key[1], [msg.header.stamp.to_sec(), twist.linear.x, twist.angular.z])

    def _on_pose_odom(self, msg: Odometry, key) -> None:
        p = msg.pose.pose
        self._add(key[0], key[1], [msg.header.stamp.to_sec(), p.position.x, p.position.y, quaternion_to_yaw(p.orientation)])

    def _on_amcl(self, msg: PoseWithCovarianceStamped, ns: str) -> None:
        p = msg.pose.pose
        self._add(ns, "amcl_pose", [msg.header.stamp.to_sec(), p.position.x, p.position.y, quaternion_to_yaw(p.orientation)])

    def snapshot(self) -> Dict[str, Dict[str, List[list]]]:
        with self.lock:
            return {ns: {kind: list(rows) for kind, rows in kinds.items()} for ns, kinds in self.records.items()}


def main(argv: Sequence[str]) -> int:
    """`sim_to_real probe --out FILE [--robots "tb3_0 tb3_1"]`: records until shutdown, then writes FILE."""
    parser = argparse.ArgumentParser(prog="sim_to_real probe")
    parser.add_argument("--out", required=True)
    parser.add_argument("--robots", default="tb3_0 tb3_1")
    args = parser.parse_args(list(argv))
    rospy.init_node("graph_probe")
    probe = GraphProbe(args.robots.split())
    rospy.on_shutdown(lambda: write_result(Path(args.out), probe.snapshot()))
    rospy.spin()
    return 0
