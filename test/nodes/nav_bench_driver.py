#!/usr/bin/env python3
"""Keeps every robot navigating without pause (the next goal is sent the moment the last one
ends) and measures the whole graph's real-time factor over ``~sim_duration`` seconds of
simulation time, after ``~warmup``. Also records the CPU time each node of the graph used in
that window (from /proc), writes ``~result_file`` (JSON) and shuts down (the launch file marks
this node required, so the whole graph stops).

Goals go straight to the action's goal topic and only results are listened to: an action
client would also take every robot's feedback (one message per control cycle) and status, whose
cost is the driver's, not the navigation's that the benchmark measures."""
import json
import math
import os
import threading
import time
import xmlrpc.client

import rosgraph
import rospy
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult

TICKS_PER_SECOND = os.sysconf("SC_CLK_TCK")


def node_cpu_seconds():
    """CPU seconds (user + system) used so far by every node registered with the master."""
    master = rosgraph.Master("/nav_bench_driver")
    usage = {}
    names = set()
    for group in master.getSystemState():
        for _, nodes in group:
            names.update(nodes)
    for name in sorted(names):
        try:
            pid = xmlrpc.client.ServerProxy(master.lookupNode(name)).getPid("/nav_bench_driver")[2]
            with open("/proc/%d/stat" % pid) as stat:
                fields = stat.read().rsplit(")", 1)[1].split()
            usage[name] = (int(fields[11]) + int(fields[12])) / TICKS_PER_SECOND
        except (OSError, xmlrpc.client.Error, rosgraph.MasterError, IndexError, ValueError):
            continue
    return usage


class Driver:
    def __init__(self):
        self.robots = rospy.get_param("~robots")
        self.goals = rospy.get_param("~goals")
        self.outcomes = {}
        self.active = {}  # robot -> id of its goal
        self.sent = 0
        self.finished = []  # robots whose goal ended: the main loop sends the next one
        self.lock = threading.Lock()
        self.goal_pubs = {ns: rospy.Publisher(ns + "/move_base/goal", MoveBaseActionGoal, queue_size=10)
                          for ns in self.robots}
        self.result_subs = [rospy.Subscriber(ns + "/move_base/result", MoveBaseActionResult, self.done,
                                             callback_args=ns, queue_size=10) for ns in self.robots]
        deadline = time.time() + 60.0
        while not all(self.goal_pubs[ns].get_num_connections() > 0 and sub.get_num_connections() > 0
                      for ns, sub in zip(self.robots, self.result_subs)):
            if time.time() > deadline or rospy.is_shutdown():
                raise RuntimeError("move_base action topics not connected for every robot")
            time.sleep(0.05)
        self.next_goal = {ns: i * 3 % len(self.goals) for i, ns in enumerate(self.robots)}

    def send(self, ns):
        x, y, yaw = self.goals[self.next_goal[ns]]
        self.next_goal[ns] = (self.next_goal[ns] + 1) % len(self.goals)
        self.sent += 1
        goal = MoveBaseActionGoal()
        goal.header.stamp = rospy.Time.now()
        goal.goal_id.stamp = goal.header.stamp
        goal.goal_id.id = "nav_bench_driver-%s-%d" % (ns, self.sent)
        goal.goal.target_pose.header.frame_id = "map"
        goal.goal.target_pose.pose.position.x, goal.goal.target_pose.pose.position.y = x, y
        goal.goal.target_pose.pose.orientation.z = math.sin(yaw / 2.0)
        goal.goal.target_pose.pose.orientation.w = math.cos(yaw / 2.0)
        with self.lock:
            self.active[ns] = goal.goal_id.id
        self.goal_pubs[ns].publish(goal)

    def done(self, msg, ns):
        state = msg.status.status
        name = {GoalStatus.SUCCEEDED: "succeeded", GoalStatus.ABORTED: "aborted",
                GoalStatus.PREEMPTED: "preempted"}.get(state, "state_%d" % state)
        with self.lock:
            if self.active.get(ns) != msg.status.goal_id.id:
                return  # not this driver's current goal
            del self.active[ns]
            self.outcomes[name] = self.outcomes.get(name, 0) + 1
            self.finished.append(ns)

    def resend(self):
        with self.lock:
            finished, self.finished = self.finished, []
        for ns in finished:
            self.send(ns)


def main():
    rospy.init_node("nav_bench_driver")
    warmup = rospy.get_param("~warmup", 5.0)
    duration = rospy.get_param("~sim_duration", 120.0)
    driver = Driver()
    for ns in driver.robots:
        driver.send(ns)
    while rospy.Time.now().to_sec() < warmup and not rospy.is_shutdown():
        driver.resend()
        time.sleep(0.002)
    cpu0, wall0, sim0 = node_cpu_seconds(), time.time(), rospy.Time.now().to_sec()
    driver.outcomes.clear()
    while rospy.Time.now().to_sec() < sim0 + duration and not rospy.is_shutdown():
        driver.resend()
        time.sleep(0.002)
    cpu1, wall1, sim1 = node_cpu_seconds(), time.time(), rospy.Time.now().to_sec()
    result = {"robots": len(driver.robots), "sim_seconds": sim1 - sim0, "wall_seconds": wall1 - wall0,
              "real_time_factor": (sim1 - sim0) / (wall1 - wall0), "goal_outcomes": driver.outcomes,
              "cpu_seconds": {name: round(cpu1[name] - cpu0.get(name, 0.0), 3) for name in cpu1}}
    with open(rospy.get_param("~result_file"), "w") as out:
        json.dump(result, out, indent=1)
    rospy.signal_shutdown("benchmark done")


if __name__ == "__main__":
    main()
