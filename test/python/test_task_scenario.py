"""Scenario files: the shipped lab scenarios are what docs/guide/evaluation.md says, and every
malformed fixture (test/data/scenarios/) gives its one-line error naming file, element and
problem, also through the `evaluate` command (exit 2, no traceback)."""
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from scipy import ndimage

from marl_mrta.env.factory import make_env
from marl_mrta.model.occupancy_map import FREE
from marl_mrta.model.scenario import ScenarioError, load_scenario

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = ROOT / "test" / "data" / "scenarios"
START_POSES = [(0.5, 0.5, 0.0), (0.5, 4.5, 0.0), (6.5, 0.5, math.pi), (6.5, 4.5, math.pi)]


@pytest.mark.parametrize("robots", [2, 3, 4])
def test_shipped_lab_scenarios(robots):
    scenario = load_scenario(ROOT / "scenarios" / f"lab_{robots}r.xml")
    assert scenario.name == f"lab_{robots}r" and scenario.n_robots == robots
    assert [t.id for t in scenario.tasks] == ["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"]
    for robot, expected in zip(scenario.robots, START_POSES):
        assert (robot.start.x, robot.start.y, robot.start.yaw) == pytest.approx(expected, abs=1e-5)
    for i in range(1, 5):
        assert scenario.predecessors[scenario.task_index(f"B{i}")] == (scenario.task_index(f"A{i}"),)
        assert scenario.predecessors[scenario.task_index(f"A{i}")] == ()
    assert scenario.episode_timeout == 120.0
    grid_map = scenario.load_map()
    clearance = ndimage.distance_transform_edt(grid_map.grid == FREE) * grid_map.resolution
    west = [t for t in scenario.tasks if t.goal.x < 3.4]
    east = [t for t in scenario.tasks if t.goal.x > 3.6]
    assert len(west) == 4 and len(east) == 4             # both halves of the lab
    for task in scenario.tasks:
        cell = grid_map.world_to_cell(task.goal.x, task.goal.y)
        assert clearance[cell.row, cell.col] >= 0.35, task.id


def test_valid_fixture_with_overrides_and_package_map():
    scenario = load_scenario(FIXTURES / "valid.xml")
    assert scenario.reward_overrides == {"logic": {"wrong_finished": 0.0}}
    assert scenario.tasks[1].service_time == 1.5
    env = make_env(scenario)
    assert env.reward.logic_wrong_finished == 0.0 and env.reward.logic_wrong_unfinished == -5.0
    assert load_scenario(FIXTURES / "valid_package_map.xml").map_path.resolve() == (ROOT / "maps" / "lab.yaml").resolve()


MALFORMED = [
    ("unknown_task_in_precedence", '<edge before="A1" after="C9">: unknown task \'C9\''),
    ("precedence_cycle", "<precedence>: precedence has a cycle: A1 -> B1 -> A1"),
    ("goal_in_obstacle", '<task id="A1">: goal (1.75, 1.5) is inside an obstacle'),
    ("goal_off_map", '<task id="A1">: goal (9, 1) is off the map'),
    ("duplicate_task_id", '<task id="A1">: duplicate task id'),
    ("duplicate_robot_id", '<robot id="tb3_0">: duplicate robot id'),
    ("bad_robot_id", '<robot id="/burger a">: id \'/burger a\' is not a relative ROS namespace'),
    ("missing_field", "<robot id=\"tb3_1\">: missing attribute 'y'"),
    ("non_numeric_field", "<task id=\"A1\">: attribute 'x' is not a number: 'one'"),
    ("missing_nav_time", "<scenario>: missing element <nav_time>"),
    ("bad_timeout", "<episode>: timeout must be positive, got -5"),
    ("unknown_reward_key", "<reward>: logic.wrong_finishd: unknown key"),
    ("missing_map_file", "<map>: cannot load the map:"),
    ("rotated_map", "<map>: cannot load the map: "),
    ("not_xml", "file: not well-formed XML"),
    ("overlapping_starts", '<robot id="tb3_1">: start pose (0.5, 0.5) overlaps the footprint of robot tb3_0 '
                           "(0 m apart, at least 0.21 m needed)"),
    ("goals_too_close", '<task id="B1">: goal (1.3, 1) is closer than a robot\'s footprint to the goal of task A1 '
                        "(0.1 m apart, at least 0.21 m needed)"),
    ("service_beyond_timeout", '<task id="A1">: service_time 150 s does not fit in the episode timeout (120 s)'),
    ("precedence_beyond_timeout", '<task id="B1">: cannot be finished in order within the episode timeout (120 s): '
                                  "the chain A1 -> B1 needs 130 s of service alone"),
]


@pytest.mark.parametrize("name,message", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_scenario_gives_one_line(name, message):
    path = FIXTURES / f"{name}.xml"
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    text = str(error.value)
    assert "\n" not in text
    assert text.startswith(f"{path}: ")
    assert message in text
    if name == "rotated_map":   # navigation ignores the yaw, which the scenario's poses would not
        assert text.endswith("tiny_rotated.yaml: origin: yaw 1.5708 rad is not 0: move_base's costmaps and amcl "
                             "ignore a map's origin yaw; rotate the image instead")


def test_goal_where_navigation_cannot_plan_is_rejected_when_building_the_environment():
    path = FIXTURES / "goal_too_close_to_wall.xml"
    load_scenario(path)   # on a free cell: the file itself is well-formed
    with pytest.raises(ScenarioError) as error:
        make_env(path)
    assert str(error.value) == (f"{path}: <task id=\"A1\">: goal (0.05, 1): in an obstacle or the inscribed zone "
                                "of the global costmap (cost 253)")


def test_task_no_start_can_reach_is_named_when_building_the_environment():
    path = FIXTURES / "unreachable_task.xml"
    load_scenario(path)   # every goal on a free cell
    with pytest.raises(ScenarioError) as error:
        make_env(path)
    text = str(error.value)
    assert "\n" not in text and text.startswith(f"{path}: <task id=\"A2\">: goal") and "cannot be reached" in text


def test_task_only_legs_beyond_the_goal_timeout_lead_to_is_named_by_the_planners_instance():
    from marl_mrta.baselines.reference import scheduling_instance
    path = FIXTURES / "beyond_goal_timeout.xml"
    env = make_env(path)   # navigation can plan there, just not within the scenario's fixed goal timeout
    assert env.settings.goal_timeout.seconds == 60.0
    with pytest.raises(ScenarioError) as error:
        scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout)
    assert str(error.value) == (f"{path}: <task id=\"A1\">: no robot can reach its goal (15.4, 9.4): every way there "
                                f"has a leg longer than the goal timeout (60 s)")
    # With an auto goal timeout every leg is its own: the planners take it.
    env = make_env(path, goal_timeout="auto")
    assert scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout).unreachable_tasks() == []


@pytest.mark.parametrize("name,robots,tasks", [("site_8r", 8, 16), ("site_16r", 16, 32)])
def test_shipped_site_scenarios(name, robots, tasks):
    scenario = load_scenario(ROOT / "scenarios" / f"{name}.xml")
    assert (scenario.n_robots, scenario.n_tasks, scenario.map_path.name) == (robots, tasks, "site.yaml")
    stage = {t.category: {u.service_time for u in scenario.tasks if u.category == t.category} for t in scenario.tasks}
    assert sorted(stage) == ["A", "B", "C"] and stage == {"A": {3.0}, "B": {4.0}, "C": {2.0}}
    for j, task in enumerate(scenario.tasks):   # three stages: B after A tasks, C after B tasks
        before = {scenario.tasks[p].category for p in scenario.predecessors[j]}
        assert before == {"A": set(), "B": {"A"}, "C": {"B"}}[task.category], task.id
    assert sum(len(p) == 2 for p in scenario.predecessors) >= tasks // 3   # two-predecessor joins


@pytest.mark.parametrize("name", ["precedence_cycle", "goal_too_close_to_wall", "unreachable_task", "overlapping_starts",
                                  "beyond_goal_timeout"])
def test_evaluate_command_reports_one_line_and_exit_2(name, tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    result = subprocess.run([sys.executable, str(ROOT / "scripts" / "evaluate"), "--method", "random",
                             "--scenario", str(FIXTURES / f"{name}.xml"), "--episodes", "1", "--quiet",
                             "--out", str(tmp_path / "out.json")],
                            capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"evaluate: {FIXTURES / name}.xml: ")
    assert not (tmp_path / "out.json").exists()


def test_a_scenario_without_nav_time_is_told_how_to_get_one_and_travel_table_suggests_it(capsys):
    """The error names the command that suggests the thresholds, and that command reads the file."""
    from marl_mrta.apps.travel_table import main as travel_table_main
    path = FIXTURES / "missing_nav_time.xml"
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    assert str(error.value).endswith(f"`rosrun marl_mrta travel_table {path}` suggests them)")
    assert load_scenario(path, nav_time_required=False).nav_thresholds is None
    assert travel_table_main([str(path)]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith('suggested <nav_time t_min="') and last.endswith("(scenario has none)")
