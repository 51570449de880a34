#!/usr/bin/env python3
"""Keeps every robot navigating without pause (the next goal is sent the moment the last one
ends) and measures the whole graph's real-time factor over ``~sim_duration`` seconds of
simulation time, after ``~warmup``. Also records the CPU time each node of the graph used in
that window (from /proc), writes ``~result_file`` (JSON) and shuts down (the launch file marks
this node required, so the whole graph stops).

Goals go through ros/move_base_link.py (the action's goal, status and result topics): an action
client would also take every robot's feedback (one message per control cycle), whose cost is the
driver's, not the navigation's that the benchmark measures."""
import json
import os
import time
import xmlrpc.client

import rosgraph
import rospy
from actionlib_msgs.msg import GoalStatus

from marl_mrta.ros.move_base_link import MoveBaseLink

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
        self.links = {ns: MoveBaseLink(ns, "map") for ns in self.robots}
        deadline = time.time() + 60.0
        while not all(link.connected() for link in self.links.values()):
            if time.time() > deadline or rospy.is_shutdown():
                raise RuntimeError("move_base action topics not connected for every robot")
            time.sleep(0.05)
        self.next_goal = {ns: i * 3 % len(self.goals) for i, ns in enumerate(self.robots)}

    def send(self, ns):
        x, y, yaw = self.goals[self.next_goal[ns]]
        self.next_goal[ns] = (self.next_goal[ns] + 1) % len(self.goals)
        self.links[ns].send(x, y, yaw)

    def resend(self):
        """Counts every goal that has ended and sends that robot its next one."""
        for ns, link in self.links.items():
            result = link.result
            if result is None:
                continue
            name = {GoalStatus.SUCCEEDED: "succeeded", GoalStatus.ABORTED: "aborted",
                    GoalStatus.PREEMPTED: "preempted"}.get(result.state, "state_%d" % result.state)
            self.outcomes[name] = self.outcomes.get(name, 0) + 1
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
