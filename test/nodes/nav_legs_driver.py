#!/usr/bin/env python3
"""Drives one robot through a list of legs (ros/leg_runner.py) with whatever navigation runs and
writes what it did on each to ``~result_file`` (JSON), then shuts the graph down (the launch file
marks this node required). launch/nav_legs.launch starts it; bench_nav_vs_stock reads the file.

Parameters: ``~legs`` ([[sx, sy, syaw, gx, gy, gyaw, noise_seed], ...], map frame),
``~robot`` (tb3_0), ``~localization`` (true: a particle filter localises the robot and is
re-initialised at every leg's start), ``~goal_timeout`` (s of sim time), ``~result_file``.
A graph that stops answering ends the run with the legs driven so far and the reason."""
import json

import rospy

from marl_mrta.evaluation.nav_comparison import Leg, LegTimings
from marl_mrta.ros.leg_runner import LegRunner
from marl_mrta.ros.sim_clock import SimulatorLost


def main():
    rospy.init_node("nav_legs_driver")
    legs = [Leg.from_list(values) for values in rospy.get_param("~legs")]
    runner = LegRunner(rospy.get_param("~robot", "tb3_0"), rospy.get_param("~localization", False),
                       LegTimings(goal_timeout=rospy.get_param("~goal_timeout", LegTimings.goal_timeout)))
    records, error = [], ""
    try:
        runner.wait_ready(rospy.get_param("~graph_wait", 60.0))
        for index, leg in enumerate(legs):
            record = runner.drive(index, leg)
            rospy.loginfo("leg %d: %s in %.2f s, %.2f m", index, record.outcome, record.time, record.path_length)
            records.append(record.to_dict())
    except SimulatorLost as lost:
        error = str(lost)
        rospy.logerr("nav_legs_driver: %s", error)
    with open(rospy.get_param("~result_file"), "w") as out:
        json.dump({"legs": records, "error": error}, out, indent=1)
    rospy.signal_shutdown("legs driven")


if __name__ == "__main__":
    main()
