#!/usr/bin/env python3
"""rostest: free run at rtf 1 keeps sim time with the wall clock (within ~tolerance, 10 %).

Samples /clock against the wall clock over ``~wall_seconds``. The simulator paces itself on
absolute wall-clock targets, so short delays on a busy machine are caught up, not summed.
"""
import time
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Clock


class RealTimeTest(unittest.TestCase):
    def test_sim_time_tracks_wall_time(self):
        wall_seconds = float(rospy.get_param("~wall_seconds", 8.0))
        tolerance = float(rospy.get_param("~tolerance", 0.10))
        rtf = float(rospy.get_param("/simulator/rtf"))
        rospy.wait_for_message("/clock", Clock, timeout=60)
        time.sleep(1.0)  # past start-up
        sim_start, wall_start = rospy.Time.now(), time.monotonic()
        time.sleep(wall_seconds)
        sim_end, wall_end = rospy.Time.now(), time.monotonic()
        factor = (sim_end - sim_start).to_sec() / (wall_end - wall_start)
        rospy.loginfo("sim_realtime: %.3f sim s per wall s (rtf %.1f)", factor, rtf)
        self.assertAlmostEqual(factor / rtf, 1.0, delta=tolerance)


if __name__ == "__main__":
    rospy.init_node("sim_realtime_test")
    rostest.rosrun("marl_mrta", "sim_realtime", RealTimeTest)
