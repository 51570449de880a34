"""rviz's configuration for any team: one display group per robot of every arena, topics and
robot descriptions in that robot's namespace, one task-marker display per arena."""
from pathlib import Path

import yaml

from marl_mrta.common.robot_names import arena_namespaces, default_robot_names
from marl_mrta.ros.rviz_config import team_config

TEMPLATE = yaml.safe_load((Path(__file__).resolve().parents[2] / "rviz" / "marl_mrta.rviz").read_text())


def _displays(config):
    return config["Visualization Manager"]["Displays"]


def test_sixteen_robots_get_a_group_each_in_their_own_namespace():
    namespaces = arena_namespaces(default_robot_names(16), 1)
    config = team_config(TEMPLATE, namespaces, 1)
    groups = [d for d in _displays(config) if d["Class"] == "rviz/Group"]
    assert [g["Name"] for g in groups] == namespaces
    last = groups[-1]["Displays"]
    topics = {d["Name"]: d.get("Topic") for d in last}
    assert topics["LaserScan"] == "/tb3_15/scan" and topics["Odometry"] == "/tb3_15/odom"
    assert next(d for d in last if d["Name"] == "RobotModel")["Robot Description"] == "tb3_15/robot_description"
    assert len({g["Displays"][1]["Color"] for g in groups}) > 1            # robots told apart
    assert [d["Marker Topic"] for d in _displays(config) if d["Class"] == "rviz/MarkerArray"] == ["/task_markers"]
    assert any(d["Class"] == "rviz/Map" for d in _displays(config))       # the rest of the template stays


def test_arenas_get_their_robots_and_their_markers():
    config = team_config(TEMPLATE, arena_namespaces(default_robot_names(2), 3), 3)
    names = [d["Name"] for d in _displays(config) if d["Class"] == "rviz/Group"]
    assert names == ["arena_0/tb3_0", "arena_0/tb3_1", "arena_1/tb3_0", "arena_1/tb3_1", "arena_2/tb3_0",
                     "arena_2/tb3_1"]
    markers = [d["Marker Topic"] for d in _displays(config) if d["Class"] == "rviz/MarkerArray"]
    assert markers == ["/arena_0/task_markers", "/arena_1/task_markers", "/arena_2/task_markers"]
