"""`rviz_view`: rviz with the package's configuration for this team (ros/rviz_config.py): every
robot of every arena (~robot_names, or tb3_0 ... for ~robots; ~arenas) and each arena's task markers.
The configuration is written to ~/.ros/marl_mrta_<robots>x<arenas>.rviz, then rviz replaces this process."""
from __future__ import annotations

import os
from pathlib import Path

import rospy

from marl_mrta.common.paths import package_root
from marl_mrta.common.robot_names import default_robot_names, name_list
from marl_mrta.ros.rviz_config import write_team_config


def main() -> int:
    rospy.init_node("rviz_view", anonymous=True)
    robots, arenas = int(rospy.get_param("~robots", 2)), int(rospy.get_param("~arenas", 1))
    names = name_list(rospy.get_param("~robot_names", "")) or default_robot_names(robots)
    if not names or arenas < 1:
        rospy.logfatal(f"rviz_view: ~robots and ~arenas must be at least 1, got {robots} and {arenas}")
        return 2
    robots = len(names)
    out = Path(os.environ.get("ROS_HOME", Path.home() / ".ros")) / f"marl_mrta_{robots}x{arenas}.rviz"
    write_team_config(package_root() / "rviz" / "marl_mrta.rviz", out, names, arenas)
    rospy.loginfo(f"rviz_view: {robots} robot(s) x {arenas} arena(s): {out}")
    os.execvp("rviz", ["rviz", "-d", str(out)])
    return 0
