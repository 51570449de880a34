"""A scenario's robot ids are its robots' namespaces in the simulation too: tasks.launch hands them
to the simulator, navigation, robot descriptions and rviz (common/robot_names.py); without names
robots are tb3_0 ... (the ROS graph itself: rostest task_named_robots)."""
import os

import pytest

from marl_mrta.common.robot_names import arena_namespaces, default_robot_names, name_list
from marl_mrta.ros.launch_args import scenario_value

roslaunch = pytest.importorskip("roslaunch")

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
NAMED = os.path.join(REPO, "test", "data", "scenarios", "named_robots.xml")


@pytest.fixture(autouse=True)
def package_path(monkeypatch):
    """$(find marl_mrta) resolves to this checkout even without a sourced workspace."""
    monkeypatch.setenv("ROS_PACKAGE_PATH", REPO + os.pathsep + os.environ.get("ROS_PACKAGE_PATH", ""))


def test_names_and_their_arenas():
    assert default_robot_names(3) == ["tb3_0", "tb3_1", "tb3_2"]
    assert name_list("a, b c") == ["a", "b", "c"] and name_list(["a", "b"]) == ["a", "b"] and name_list(None) == []
    assert arena_namespaces(["a", "b"], 1) == ["a", "b"]
    assert arena_namespaces(["a", "b"], 2) == ["arena_0/a", "arena_0/b", "arena_1/a", "arena_1/b"]


def test_the_scenario_gives_its_robot_ids():
    assert scenario_value(NAMED, "robot_names") == "burger_a ops/burger_b"
    assert scenario_value(os.path.join(REPO, "scenarios", "lab_3r.xml"), "robot_names") == "tb3_0 tb3_1 tb3_2"


@pytest.mark.parametrize("nav", ["builtin", "stock"])
def test_tasks_launch_runs_the_scenarios_robots(nav):
    config = roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", "tasks.launch"), ["roslaunch", "scenario:=" + NAMED, "nav:=" + nav,
                                                          "nodelets:=false"])], None, verbose=False)
    nodes = {n.namespace + n.name for n in config.nodes}
    params = {name: p.value for name, p in config.params.items()}
    assert params["/simulator/robot_names"] == "burger_a ops/burger_b"
    for robot in ("burger_a", "ops/burger_b"):
        assert f"/{robot}/move_base" in nodes and f"/{robot}/robot_state_publisher" in nodes
        assert params[f"/{robot}/move_base/global_costmap/robot_base_frame"] == f"{robot}/base_footprint"
    assert not [n for n in nodes if n.startswith("/tb3_")]


@pytest.mark.slow
def test_sim_launch_without_names_keeps_tb3_and_rviz_gets_the_names():
    config = roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", "sim.launch"), ["roslaunch", "robots:=2", "nav:=builtin", "rviz:=true"])],
        None, verbose=False)
    nodes = {n.namespace + n.name for n in config.nodes}
    params = {name: p.value for name, p in config.params.items()}
    assert "/simulator/robot_names" not in params
    assert {"/tb3_0/move_base", "/tb3_1/move_base"} <= nodes
    config = roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", "sim.launch"),
          ["roslaunch", "robots:=2", "robot_names:=a b", "arenas:=2", "nav:=builtin", "rviz:=true"])],
        None, verbose=False)
    nodes = {n.namespace + n.name for n in config.nodes}
    params = {name: p.value for name, p in config.params.items()}
    assert {"/arena_0/a/move_base", "/arena_1/b/move_base", "/arena_1/b/robot_state_publisher"} <= nodes
    assert params["/rviz/robot_names"] == "a b"
