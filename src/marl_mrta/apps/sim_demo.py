"""Headless simulator demo: the robots drive a square in lock-step; prints what was measured.

Each robot of the running simulator (started by launch/sim_demo.launch with lockstep:=true)
drives ``~laps`` laps of a square of side ``~side`` metres from its start pose, turning
towards ``~centre`` (the middle of the lab), with a go-to-waypoint controller on its
odometry. Reported per robot and in total: distance driven (ground truth), sim time, wall
time, real-time factor, collision events, and how far each robot ended from where it started.
Writes the figures to ``~output`` (JSON) when set.
"""
import math
import threading
import time
from pathlib import Path

import rospy
from nav_msgs.msg import Odometry

from marl_mrta.common.results import write_result
from marl_mrta.msg import CollisionEvent
from marl_mrta.ros.lockstep import LockstepController

WAYPOINT_TOLERANCE = 0.03   # m
HEADING_TOLERANCE = 0.15    # rad: turn on the spot beyond this
MAX_LINEAR = 0.20           # m/s
MAX_ANGULAR = 1.5           # rad/s


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def wrap(angle):
    return math.atan2(math.sin(angle), math.cos(angle))


class RobotRoute:
    """A square in the robot's odometry frame (which starts at its start pose), driven by
    turning towards the next corner and then driving to it."""

    def __init__(self, ns, start, centre, side, laps):
        self.ns = ns
        x, y, yaw = start
        heading = (math.cos(yaw), math.sin(yaw))
        to_centre = (centre[0] - x, centre[1] - y)
        turn = 1.0 if heading[0] * to_centre[1] - heading[1] * to_centre[0] >= 0.0 else -1.0
        corners = [(side, 0.0), (side, turn * side), (0.0, turn * side), (0.0, 0.0)]
        self.waypoints = corners * laps
        self.start = (x, y)
        self.distance = 0.0
        self.last_truth = None
        self.finished_at = None

    def command(self, odom):
        """(linear, angular) towards the current waypoint; None once the route is done."""
        p = odom.pose.pose.position
        while self.waypoints:
            wx, wy = self.waypoints[0]
            if math.hypot(wx - p.x, wy - p.y) > WAYPOINT_TOLERANCE:
                break
            self.waypoints.pop(0)
        if not self.waypoints:
            return None
        wx, wy = self.waypoints[0]
        error = wrap(math.atan2(wy - p.y, wx - p.x) - yaw_of(odom.pose.pose.orientation))
        angular = max(-MAX_ANGULAR, min(MAX_ANGULAR, 2.5 * error))
        if abs(error) > HEADING_TOLERANCE:
            return 0.0, angular
        return min(MAX_LINEAR, 1.5 * math.hypot(wx - p.x, wy - p.y)), angular

    def track(self, truth):
        p = truth.pose.pose.position
        if self.last_truth is not None:
            self.distance += math.hypot(p.x - self.last_truth[0], p.y - self.last_truth[1])
        self.last_truth = (p.x, p.y)


def main():
    rospy.init_node("sim_demo")
    robots_count = int(rospy.get_param("/simulator/robots"))
    arenas = int(rospy.get_param("/simulator/arenas", 1))
    starts = rospy.get_param("/simulator/start_poses")[:robots_count]
    side = float(rospy.get_param("~side", 0.8))
    laps = int(rospy.get_param("~laps", 1))
    output = rospy.get_param("~output", "")
    time_limit = float(rospy.get_param("~time_limit", 120.0))  # s of sim time
    centre = rospy.get_param("~centre", [3.5, 2.5])  # the squares turn towards it (the lab's middle)
    if arenas != 1:
        rospy.logfatal("sim_demo: runs on one arena, the simulator has %d", arenas)
        raise SystemExit(1)
    names = ["tb3_%d" % i for i in range(robots_count)]
    routes = {ns: RobotRoute(ns, start, centre, side, laps) for ns, start in zip(names, starts)}
    collisions = []
    lock = threading.Lock()

    def on_collision(msg):
        with lock:
            collisions.append((msg.stamp.to_sec(), msg.robot, msg.other))
        rospy.loginfo("sim_demo: collision at %.2f s: %s with %s", msg.stamp.to_sec(), msg.robot, msg.other)

    for ns in names:  # every ground-truth message, in order: the distance driven
        rospy.Subscriber(ns + "/base_pose_ground_truth", Odometry, lambda msg, ns=ns: routes[ns].track(msg),
                         queue_size=1000)
    rospy.Subscriber("/simulator/collisions", CollisionEvent, on_collision, queue_size=100)
    progress = {"next_report": 10.0}

    def on_tick(tick, odom):
        """Commands from each robot's odometry of this very tick (so runs repeat exactly)."""
        now = tick.stamp.to_sec()
        pending = [r for r in routes.values() if r.finished_at is None]
        if not pending or now >= time_limit:
            return False
        for route in pending:
            command = route.command(odom[route.ns]) if route.ns in odom else (0.0, 0.0)
            if command is None:
                route.finished_at = now
                command = (0.0, 0.0)
            controller.command(route.ns, *command)
        if now >= progress["next_report"]:
            rospy.loginfo("sim_demo: %.0f s of sim time, %d of %d robots still driving", now, len(pending), len(routes))
            progress["next_report"] += 10.0
        return True

    controller = LockstepController(names, on_tick, state_topic="odom")
    rospy.loginfo("sim_demo: %d robots, %d lap(s) of a %.2f m square each, in lock-step", len(names), laps, side)
    wall_start = time.monotonic()
    controller.start()
    while not rospy.is_shutdown() and not controller.finished.wait(0.1):
        pass
    wall = time.monotonic() - wall_start
    sim = rospy.get_time()
    rospy.rostime.wallsleep(0.3)  # the last collision events

    per_robot = {}
    for ns, route in routes.items():
        end = route.last_truth or route.start
        per_robot[ns] = {
            "distance_m": round(route.distance, 3),
            "finished_at_s": route.finished_at,
            "end_to_start_m": round(math.hypot(end[0] - route.start[0], end[1] - route.start[1]), 3),
            "collisions": sum(1 for c in collisions if c[1] == ns),
        }
    result = {
        "robots": len(names),
        "route": {"square_side_m": side, "laps": laps},
        "sim_seconds": round(sim, 2),
        "wall_seconds": round(wall, 2),
        "real_time_factor": round(sim / wall, 1) if wall > 0 else None,
        "distance_m": round(sum(r["distance_m"] for r in per_robot.values()), 3),
        "collisions": len(collisions),
        "all_finished": all(r.finished_at is not None for r in routes.values()),
        "per_robot": per_robot,
    }
    print("")
    print("sim_demo: %d robots, %d lap(s) of a %.2f m square, lock-step" % (len(names), laps, side))
    print("  %-8s %10s %12s %14s %10s" % ("robot", "driven [m]", "done at [s]", "end-start [m]", "collisions"))
    for ns, r in per_robot.items():
        done = "%.1f" % r["finished_at_s"] if r["finished_at_s"] is not None else "-"
        print("  %-8s %10.2f %12s %14.3f %10d" % (ns, r["distance_m"], done, r["end_to_start_m"], r["collisions"]))
    print("  total: %.2f m driven, %.1f s sim time in %.1f s wall time (%.1f x real time), %d collision events" % (
        result["distance_m"], sim, wall, result["real_time_factor"] or 0.0, len(collisions)))
    if output:
        write_result(Path(output), result)
        print("  written %s" % output)
    if not result["all_finished"]:
        rospy.logerr("sim_demo: not every robot finished its route within %.0f s of sim time", time_limit)
        raise SystemExit(1)
