#!/usr/bin/env python3
"""rostest nav_stock: the stock navigation stack (move_base with navfn + DWA, fake_localization,
map_server of ros-planning/navigation) in the simulator on the lab map, in real time (the stock
nodes take no part in the lock-step). One robot drives the first goals of the tour of
nav_goals_test.py; each succeeds within the tour's tolerances, and no node of the graph logs at
ERROR level or above (/rosout).

Without the stock packages (``~stock_available`` false, set by the .test file) the test is
skipped, and the skip is written into the JUnit result file as such (nav_goals_test's
rosrun_marking_skips).
"""
import os
import sys

import rospy
from actionlib_msgs.msg import GoalStatus

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from nav_goals_test import XY_TOLERANCE, YAW_TOLERANCE, Robot, angle_diff, rosrun_marking_skips, tour_goals  # noqa: E402
from stock_test_helpers import StockGraphCase  # noqa: E402

STOCK_GOALS = 4  # of the tour: the west half, with legs past both columns
#: Stock move_base (noetic-devel) may report a goal reached at once, where the robot stands: when
#: the last goal was reached while its planner thread was still planning to it, that plan comes
#: out flagged new after the result, and the next goal's controller takes it (its end is where the
#: robot is). ros-planning/navigation#949, not fixed in the source built here; seen in this test
#: under load (A2 and A4 "reached" 1.8 m away, 0 s after being sent). That stale success is told
#: by its time (the goal ended within STALE_WITHIN s of sim time, the robot still more than
#: STALE_DISTANCE m from it) and the goal is sent once more; any other result counts as it is.
STALE_WITHIN = 0.5
STALE_DISTANCE = 0.5
#: Stock DWA reports a goal reached when its control cycle finds the robot within the tolerances
#: and "stopped": turning slower than theta_stopped_vel and driving slower than trans_stopped_vel
#: (0.1 rad/s and 0.1 m/s, base_local_planner's defaults; TurtleBot3's files keep them). The robot
#: may go on at that speed until the zero command lands, a control period (10 Hz) later, so the
#: ground truth at the result may be that much past the tolerance (A4 was found 0.1716 rad off).
CONTROL_PERIOD = 1.0 / 10.0
STOPPED_YAW = 0.1 * CONTROL_PERIOD
STOPPED_XY = 0.1 * CONTROL_PERIOD


class StockTourTest(StockGraphCase):
    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        if not cls.available:
            return
        cls.robot = Robot("tb3_0")
        if not cls.robot.client.wait_for_server(rospy.Duration(60.0)):
            raise AssertionError("tb3_0/move_base action server not available")
        cls.robot.latest()

    def test_tour_goals_succeed_without_errors(self):
        self.assert_runs_stock("/tb3_0/move_base", "move_base", "move_base")
        self.assert_runs_stock("/tb3_0/fake_localization", "fake_localization", "fake_localization")
        robot = self.robot
        stale = []
        for label, goal in tour_goals()[:STOCK_GOALS]:
            robot.wait_at_rest()
            t0 = robot.send(*goal)
            state, text, t1 = robot.wait()
            if state == GoalStatus.SUCCEEDED and t1 - t0 <= STALE_WITHIN and self.distance(goal, t1) > STALE_DISTANCE:
                stale.append(label)
                rospy.logwarn("nav_stock_test: goal %s reported reached %.2f s after it was sent, %.2f m away "
                              "(ros-planning/navigation#949): sent again", label, t1 - t0, self.distance(goal, t1))
                robot.wait_at_rest()
                robot.send(*goal)
                state, text, t1 = robot.wait()
            self.assertEqual(GoalStatus.SUCCEEDED, state, "goal %s %s ended in state %d: %s" % (label, goal, state, text))
            _, x, y, yaw, _, _ = robot.truth_at(t1)
            error_xy = ((x - goal[0]) ** 2 + (y - goal[1]) ** 2) ** 0.5
            error_yaw = abs(angle_diff(yaw, goal[2]))
            self.assertLessEqual(error_xy, XY_TOLERANCE + STOPPED_XY, "goal %s reached %.3f m away" % (label, error_xy))
            self.assertLessEqual(error_yaw, YAW_TOLERANCE + STOPPED_YAW,
                                 "goal %s reached %.4f rad off" % (label, error_yaw))
        if stale:
            print("nav_stock: goals %s reported reached at once where the robot stood (ros-planning/navigation#949), "
                  "sent again" % ", ".join(stale))
        self.assert_no_error_logged()

    def distance(self, goal, stamp):
        _, x, y, _, _, _ = self.robot.truth_at(stamp)
        return ((x - goal[0]) ** 2 + (y - goal[1]) ** 2) ** 0.5


if __name__ == "__main__":
    rospy.init_node("nav_stock_test")
    rosrun_marking_skips("nav_stock", StockTourTest, sys.argv)
