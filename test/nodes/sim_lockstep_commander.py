#!/usr/bin/env python3
"""A scripted lock-step controller for the simulator's rostests.

Registers as the lock-step controller of ``~robots`` (marl_mrta.ros.lockstep), answers every
tick with a command that depends only on the tick number (sent on every second tick, like a
10 Hz controller), and stops answering at ``~final_tick``. With ``~period`` 0.1 (s) it acts
only on those ticks and lets the simulator run through the others without waiting (next_stamp). It writes the ground-truth poses
stamped at that tick (as exact float hex strings) and the collision events seen to
``~result_file`` (JSON), and exits.
"""
import json
import math
import threading

import rospy

from marl_mrta.msg import CollisionEvent
from marl_mrta.ros.lockstep import LockstepController


def scripted_command(tick, robot_index):
    """The same (linear, angular) velocity for the same tick and robot, every run."""
    linear = 0.22 * math.sin(0.02 * tick + robot_index)
    angular = 2.0 * math.cos(0.031 * tick * (robot_index + 1))
    return linear, angular


def main():
    rospy.init_node("sim_lockstep_commander")
    robots = rospy.get_param("~robots", ["tb3_0", "tb3_1"])
    final_tick = int(rospy.get_param("~final_tick", 600))
    result_file = rospy.get_param("~result_file")
    period = float(rospy.get_param("~period", 0.0))
    collisions, final_poses = [], {}
    lock = threading.Lock()

    def on_collision(msg):
        with lock:
            collisions.append([msg.stamp.to_nsec(), msg.robot, msg.other])

    def on_tick(tick, states):
        if tick.tick >= final_tick:
            for ns in robots:
                state = states[ns]
                if state.header.stamp != tick.stamp:
                    raise RuntimeError("%s: no ground truth at the final tick" % ns)
                p, q = state.pose.pose.position, state.pose.pose.orientation
                final_poses[ns] = [float(v).hex() for v in (p.x, p.y, q.z, q.w)]
            return False
        if tick.tick % 2 == 0:
            for i, ns in enumerate(robots):
                controller.command(ns, *scripted_command(tick.tick, i))
        return True

    rospy.Subscriber("/simulator/collisions", CollisionEvent, on_collision, queue_size=100)
    controller = LockstepController(robots, on_tick, period=period)
    controller.start()
    while not rospy.is_shutdown() and not controller.finished.wait(0.1):
        pass
    rospy.rostime.wallsleep(0.5)  # collision events of the last ticks travel on another connection
    with lock:
        result = {"final_tick": final_tick, "poses": final_poses, "collisions": collisions}
    with open(result_file, "w") as out:
        json.dump(result, out)
    rospy.loginfo("sim_lockstep_commander: tick %d reached, %d collision events, result in %s",
                  final_tick, len(collisions), result_file)


if __name__ == "__main__":
    main()
