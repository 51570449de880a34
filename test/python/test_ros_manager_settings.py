"""Parameters of rl_task_allocation_manager: defaults from config/task_manager.yaml, every bad
value one line naming the parameter."""
import pytest

from marl_mrta.ros.manager_settings import read_manager_settings
from marl_mrta.common.config import ConfigError, read_yaml
from marl_mrta.common.paths import default_config_path

NODE = "/rl_task_allocation_manager"


def test_defaults_come_from_the_config_file():
    defaults = read_yaml(default_config_path("task_manager.yaml")).data
    settings = read_manager_settings({"scenario": "lab.xml"}, NODE)
    assert settings.scenario == "lab.xml"
    assert settings.mask is None and settings.task_config is None and settings.reward_config is None
    assert settings.executor.simulator_lost_after == defaults["simulator_lost_after"]
    assert settings.executor.align_period == defaults["align_period"]
    assert settings.executor.graph_wait == defaults["graph_wait"]
    assert settings.marker_period == defaults["marker_period"]
    assert settings.executor.map_frame == "map" and settings.executor.robot_prefix == ""


def test_the_wall_time_limit_grows_with_the_team():
    """simulator_lost_after covers 4 robots; 8 and 16 robots, whose ticks wait for every
    controller on the same CPUs, get twice and four times as long."""
    settings = read_manager_settings({"scenario": "s.xml", "simulator_lost_after": 2.5}, NODE).executor
    assert [settings.lost_after(n) for n in (1, 2, 4, 8, 16)] == [2.5, 2.5, 2.5, 5.0, 10.0]


def test_parameters_override_defaults_and_the_output_parameter_is_ignored():
    settings = read_manager_settings({"scenario": "s.xml", "mask": "logic", "arena": 2, "robot_prefix": "arena_2/",
                                      "simulator_lost_after": 1, "env": {"n_agents": 2}}, NODE)
    assert settings.mask == "logic"
    assert settings.executor.arena == 2 and settings.executor.robot_prefix == "arena_2/"
    assert settings.executor.simulator_lost_after == 1.0


def test_the_goal_timeout_is_the_scenarios_or_the_task_configs_unless_given():
    """A launch file's goal_timeout arrives as a string (type="str"): "" is not given."""
    assert read_manager_settings({"scenario": "s.xml"}, NODE).goal_timeout is None
    assert read_manager_settings({"scenario": "s.xml", "goal_timeout": ""}, NODE).goal_timeout is None
    assert read_manager_settings({"scenario": "s.xml", "goal_timeout": "auto"}, NODE).goal_timeout == "auto"
    assert read_manager_settings({"scenario": "s.xml", "goal_timeout": "90"}, NODE).goal_timeout == 90.0
    assert read_manager_settings({"scenario": "s.xml", "goal_timeout": 45}, NODE).goal_timeout == 45.0


def test_the_decision_mode_is_the_task_configs_unless_given():
    assert read_manager_settings({"scenario": "s.xml"}, NODE).decision_mode is None
    assert read_manager_settings({"scenario": "s.xml", "decision_mode": ""}, NODE).decision_mode is None
    assert read_manager_settings({"scenario": "s.xml", "decision_mode": "event"}, NODE).decision_mode == "event"


@pytest.mark.parametrize("params, message", [
    ({}, NODE + "/scenario: missing: give the scenario XML file"),
    ({"scenario": ""}, NODE + "/scenario: missing"),
    ({"scenario": "s.xml", "mask": "often"}, NODE + "/mask: 'often' is not one of none, finished, logic"),
    ({"scenario": "s.xml", "arena": -1}, NODE + "/arena: must be >= 0, got -1"),
    ({"scenario": "s.xml", "arena": True}, NODE + "/arena: expected an integer, got True"),
    ({"scenario": "s.xml", "simulator_lost_after": 0}, NODE + "/simulator_lost_after: must be > 0.0, got 0.0"),
    ({"scenario": "s.xml", "align_period": "1s"}, NODE + "/align_period: expected a number, got '1s'"),
    ({"scenario": "s.xml", "robot_prefix": "arena_1"}, NODE + "/robot_prefix: 'arena_1' must be empty or"),
    ({"scenario": "s.xml", "robot_prefix": "/arena_1/"}, NODE + "/robot_prefix: '/arena_1/' must be empty or"),
    ({"scenario": "s.xml", "map_frame": ""}, NODE + "/map_frame: expected a non-empty string, got ''"),
    ({"scenario": "s.xml", "goal_timeout": -5}, NODE + "/goal_timeout: must be positive, got -5 (or empty:"),
    ({"scenario": "s.xml", "goal_timeout": "soon"}, NODE + "/goal_timeout: is not a number of seconds or auto: 'soon'"),
    ({"scenario": "s.xml", "goal_timeouts": 5.0}, NODE + "/goal_timeouts: unknown parameter (did you mean goal_timeout?)"),
    ({"scenario": "s.xml", "decision_mode": "async"}, NODE + "/decision_mode: 'async' is not one of synchronous, event"),
])
def test_bad_parameters_give_one_line(params, message):
    with pytest.raises(ConfigError) as error:
        read_manager_settings(params, NODE)
    text = str(error.value)
    assert text.startswith(message)
    assert "\n" not in text


def test_real_mode_settings_come_from_the_config_file_and_the_node():
    settings = read_manager_settings({"scenario": "s.xml", "mode": "real", "localization": "amcl", "reset": "current",
                                      "go": True, "scan_silent_after": 2.5, "aborted_episode_file": "/tmp/a.json"}, NODE)
    assert settings.mode == "real"
    assert settings.real.reset == "current" and settings.real.go
    assert settings.real.reset_drive == "one_by_one"
    assert read_manager_settings({"scenario": "s.xml", "reset_drive": "together"}, NODE).real.reset_drive == "together"
    assert settings.real.limits.scan_silent_after == 2.5
    assert settings.real.limits.odom_silent_after == read_yaml(default_config_path("task_manager.yaml")).data["odom_silent_after"]
    assert settings.real.aborted_episode_file == "/tmp/a.json"
    assert settings.real.limits.scan_fit_min == 0.5 and settings.real.limits.scan_fit_lost_scans == 10
    assert read_manager_settings({"scenario": "s.xml"}, NODE).mode == "simulation"


@pytest.mark.parametrize("params, message", [
    ({"mode": "robots"}, NODE + "/mode: 'robots' is not one of simulation, real"),
    ({"mode": "real"}, NODE + "/localization: must be amcl in real mode (real robots have no ground truth), got 'ground_truth'"),
    ({"reset": "home"}, NODE + "/reset: 'home' is not one of start, current"),
    ({"reset_drive": "all"}, NODE + "/reset_drive: 'all' is not one of one_by_one, together"),
    ({"go": "yes"}, NODE + "/go: expected true or false, got 'yes'"),
    ({"odom_silent_after": 0}, NODE + "/odom_silent_after: must be > 0.0, got 0.0"),
    ({"master_lost_after": "1s"}, NODE + "/master_lost_after: expected a number, got '1s'"),
    ({"stop_hold": -1}, NODE + "/stop_hold: must be >= 0.0, got -1.0"),
    ({"scan_fit_min": 1.5}, NODE + "/scan_fit_min: must be <= 1.0, got 1.5"),
    ({"scan_fit_lost_scans": 0}, NODE + "/scan_fit_lost_scans: must be >= 1, got 0"),
    ({"scan_fit_tolerance": 0}, NODE + "/scan_fit_tolerance: must be > 0.0, got 0.0"),
    ({"scan_fit_max_turn": "fast"}, NODE + "/scan_fit_max_turn: expected a number, got 'fast'"),
])
def test_bad_real_mode_parameters_are_one_line(params, message):
    with pytest.raises(ConfigError) as error:
        read_manager_settings({"scenario": "s.xml", **params}, NODE)
    assert str(error.value) == message
