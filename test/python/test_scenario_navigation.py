"""A scenario may name its robots' navigation parameter files (<robots navigation="DIR">), for a
lab whose Burgers run navigation tuned to its floor: the embedded travel times are planned with
those files (at most at the speed their local planner drives), and the launch files load the same
directory into every robot's move_base and amcl.
A directory that is not there, a package ROS does not know, or a directory without the files is
one line, as is a map in a package ROS does not know."""
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import package_root
from marl_mrta.env.factory import make_env, scenario_travel_table
from marl_mrta.model.scenario import ScenarioError, load_scenario
from marl_mrta.ros.launch_args import scenario_value

ROOT = package_root()
LAB_2R = ROOT / "scenarios" / "lab_2r.xml"
TASKS_LAUNCH = ROOT / "launch" / "tasks.launch"


def scenario_with_navigation(tmp_path: Path, navigation: str) -> Path:
    """lab_2r with <robots navigation="..."> (its map referenced absolutely)."""
    text = LAB_2R.read_text().replace('file="../maps/lab.yaml"', f'file="{ROOT / "maps" / "lab.yaml"}"')
    assert "<robots>" in text
    path = tmp_path / "lab_2r_own_nav.xml"
    path.write_text(text.replace("<robots>", f'<robots navigation="{navigation}">'))
    return path


@pytest.fixture
def tight_nav(tmp_path: Path) -> Path:
    """config/nav with a narrower inflation: navfn's paths pass closer to the walls."""
    directory = tmp_path / "nav_tight"
    shutil.copytree(ROOT / "config" / "nav", directory)
    costmap = directory / "costmap_common_params_burger.yaml"
    text = costmap.read_text()
    assert "inflation_radius: 1.0" in text and "cost_scaling_factor: 3.0" in text
    costmap.write_text(text.replace("inflation_radius: 1.0", "inflation_radius: 0.3")
                       .replace("cost_scaling_factor: 3.0", "cost_scaling_factor: 10.0"))
    return directory


def test_the_embedded_travel_times_are_planned_with_the_scenarios_navigation_files(tmp_path, tight_nav):
    own = load_scenario(scenario_with_navigation(tmp_path, "nav_tight"))   # relative to the scenario file
    assert own.navigation_dir.resolve() == tight_nav.resolve()
    lab = load_scenario(LAB_2R)
    assert lab.navigation_dir is None
    own_table, lab_table = scenario_travel_table(own), scenario_travel_table(lab)
    assert Path(own_table.model.nav_config_dir) == tight_nav.resolve()
    # Closer to the walls the legs are shorter, some by far (leaving a corner of the grid's own
    # path aside); the poses are the same.
    assert own_table.node_poses == lab_table.node_poses
    assert own_table.length.sum() < 0.95 * lab_table.length.sum() and (own_table.length < lab_table.length - 0.5).any()
    # An environment of that scenario steps with those times.
    env = make_env(own, seed=0)
    assert np.array_equal(env.executor.table.nominal_time, own_table.nominal_time)


def test_robots_drive_no_faster_than_the_scenarios_local_planner(tmp_path, tight_nav):
    dwa = tight_nav / "dwa_local_planner_params_burger.yaml"
    text = dwa.read_text()
    assert "max_vel_x: 0.22" in text
    dwa.write_text(text.replace("max_vel_x: 0.22", "max_vel_x: 0.15"))
    table = scenario_travel_table(load_scenario(scenario_with_navigation(tmp_path, "nav_tight")))
    assert table.model.linear_speed == 0.15
    np.testing.assert_allclose(table.nominal_time, np.maximum(table.turn_time + table.length / 0.15,
                                                              table.model.min_goal_time))
    env = make_env(load_scenario(scenario_with_navigation(tmp_path, "nav_tight")), seed=0)
    assert env.executor.table.model.linear_speed == 0.15   # the embedded executor drives with it too


def test_launch_files_take_the_navigation_directory_from_the_scenario(tmp_path, tight_nav):
    own = scenario_with_navigation(tmp_path, str(tight_nav))
    assert scenario_value(str(own), "navigation") == str(tight_nav.resolve())
    assert scenario_value(str(LAB_2R), "navigation") == str(ROOT / "config" / "nav")
    # roslaunch resolves the whole graph without starting it: every move_base and amcl gets the files.
    dumped = subprocess.run(["roslaunch", "--dump-params", str(TASKS_LAUNCH), f"scenario:={own}", "nav:=builtin"],
                            capture_output=True, text=True, timeout=120)
    assert dumped.returncode == 0, dumped.stderr
    for robot in ("tb3_0", "tb3_1"):
        assert f"/{robot}/move_base/global_costmap/inflation_radius: 0.3" in dumped.stdout
        assert f"/{robot}/move_base/global_costmap/cost_scaling_factor: 10.0" in dumped.stdout
    lab = subprocess.run(["roslaunch", "--dump-params", str(TASKS_LAUNCH), f"scenario:={LAB_2R}", "nav:=builtin"],
                         capture_output=True, text=True, timeout=120)
    assert "/tb3_0/move_base/global_costmap/inflation_radius: 1.0" in lab.stdout


@pytest.mark.parametrize("navigation, problem", [
    ("no_such_dir", "navigation: {tmp}/no_such_dir is not a directory"),
    ("package://no_such_package/nav", "navigation: package://no_such_package/nav: ROS knows no package 'no_such_package'"),
])
def test_a_navigation_directory_that_is_not_there_is_one_line(tmp_path, navigation, problem):
    path = scenario_with_navigation(tmp_path, navigation)
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    assert str(error.value) == f"{path}: <robots>: {problem.format(tmp=tmp_path)}"


def test_a_navigation_directory_without_its_files_is_one_line(tmp_path):
    (tmp_path / "empty_nav").mkdir()
    with pytest.raises(ConfigError) as error:
        make_env(scenario_with_navigation(tmp_path, "empty_nav"), seed=0)
    text = str(error.value)
    assert "\n" not in text and f"with the navigation files of {(tmp_path / 'empty_nav').resolve()}" in text
    assert "costmap_common_params_burger.yaml: cannot be read" in text


def test_an_unknown_attribute_of_robots_is_one_line(tmp_path):
    path = tmp_path / "typo.xml"
    path.write_text(scenario_with_navigation(tmp_path, "x").read_text().replace("navigation=", "navigaton="))
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    assert str(error.value) == f"{path}: <robots>: unknown attribute 'navigaton'"


def test_a_map_in_a_package_ros_does_not_know_is_one_line(tmp_path):
    path = tmp_path / "unknown_package.xml"
    path.write_text(LAB_2R.read_text().replace('file="../maps/lab.yaml"', 'file="package://no_such_package/lab.yaml"'))
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    assert str(error.value) == (f"{path}: <map>: file: package://no_such_package/lab.yaml: "
                                "ROS knows no package 'no_such_package'")
