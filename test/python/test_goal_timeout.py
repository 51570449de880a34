"""Goal timeouts that follow the floor (model/goal_timeout.py): the rule, config/task.yaml and the
scenario's <episode goal_timeout> read strictly, the embedded executor failing a leg past its own
timeout and not one within it, the override order (config/task.yaml < the scenario < a command
line, `evaluate --goal-timeout` and `train --goal-timeout`), an auto episode timeout, and a 100 m
leg that a fixed 60 s refuses and auto runs through `evaluate` with no configuration edited. Bad
input is one line (exit 2 from evaluate and train)."""
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.apps.evaluate import main as evaluate
from marl_mrta.baselines.plan import SchedulingInstance
from marl_mrta.common.config import ConfigError, read_yaml
from marl_mrta.common.paths import default_config_path
from marl_mrta.env.embedded import EmbeddedExecutor
from marl_mrta.env.factory import make_env, scenario_leg_timeouts, scenario_travel_table
from marl_mrta.env.settings import load_task_settings
from marl_mrta.model.goal_timeout import (AUTO, GoalTimeout, LegTimeouts, auto_episode_timeout, check_goal_timeout,
                                          parse_timeout)
from marl_mrta.model.noise import NoiseProfile
from marl_mrta.model.scenario import ScenarioError, load_scenario
from marl_mrta.model.travel import TravelModel, TravelTable

ROOT = Path(__file__).resolve().parents[2]
LAB_2R = ROOT / "scenarios" / "lab_2r.xml"


# ---------------------------------------------------------------------------------------------- the rule

def test_a_fixed_timeout_is_every_legs_and_auto_is_factor_times_nominal_plus_margin():
    fixed = GoalTimeout(60.0, factor=2.0, margin=30.0)
    assert [fixed.leg(t) for t in (5.0, 200.0)] == [60.0, 60.0]
    assert not fixed.auto and fixed.value == 60.0 and fixed.planning_limit == 60.0
    auto = fixed.with_value(AUTO)
    assert auto.auto and auto.value == AUTO and auto.planning_limit == math.inf
    assert [auto.leg(t) for t in (0.0, 5.0, 200.0)] == [30.0, 40.0, 430.0]
    assert auto.with_value(45) == GoalTimeout(45.0, 2.0, 30.0) and auto.with_value(None) is auto


@pytest.mark.parametrize("text, value", [("auto", AUTO), (" Auto ", AUTO), ("90", 90.0), ("0.5", 0.5), (12, 12.0)])
def test_a_timeout_is_seconds_above_zero_or_auto(text, value):
    assert parse_timeout(text) == value


@pytest.mark.parametrize("text, problem", [("0", "must be positive, got 0"), (-3, "must be positive, got -3"),
                                           ("soon", "is not a number of seconds or auto: 'soon'"),
                                           ("inf", "is not finite: 'inf'"),
                                           (True, "is not a number of seconds or auto: True")])
def test_anything_else_is_one_phrase(text, problem):
    with pytest.raises(ValueError) as error:
        parse_timeout(text)
    assert str(error.value) == problem
    with pytest.raises(ConfigError) as error:
        check_goal_timeout(text, "--goal-timeout")
    assert str(error.value) == f"--goal-timeout: {problem}"
    assert check_goal_timeout("", "x") is None and check_goal_timeout(None, "x") is None


def test_each_leg_from_where_its_robot_stands():
    nominal = [[0.0, 1.0, 10.0, 50.0], [1.0, 0.0, 20.0, 60.0], [10.0, 20.0, 0.0, 100.0], [50.0, 60.0, 100.0, 0.0]]
    legs = LegTimeouts(GoalTimeout(None, 2.0, 30.0), 2, nominal)
    assert [legs.limit(0, 0), legs.limit(1, 1)] == [50.0, 150.0] and legs.step_limit([0, 1]) == 150.0
    legs.reached(0, 0)
    assert legs.limit(0, 1) == 230.0 and legs.step_limit([1, None]) == 230.0
    legs.reset()
    assert legs.limit(0, 1) == 130.0
    assert LegTimeouts(GoalTimeout(60.0), 2).step_limit([None, None]) == 60.0
    with pytest.raises(ValueError):
        LegTimeouts(GoalTimeout(None), 2)   # auto needs the travel table


def test_an_auto_episode_timeout_is_the_factor_times_each_task_entered_over_its_shortest_leg_and_served():
    nominal = [[0.0, 12.0, 40.0], [12.0, 0.0, 33.0], [40.0, 33.0, 0.0]]   # one robot, tasks 0 and 1
    # shortest legs in: 12 (start -> 0) and 33 (0 -> 1); services 2 and 4: 3 x 51 = 153 -> 160
    assert auto_episode_timeout(nominal, 1, [2.0, 4.0], 3.0) == 160.0
    assert auto_episode_timeout(nominal, 1, [2.0, 4.0], 1.0) == 60.0


# ---------------------------------------------------------------------------------------------- settings

def test_the_package_default_is_auto_with_the_files_factor_and_margin():
    data = read_yaml(default_config_path("task.yaml")).data
    settings = load_task_settings()
    assert data["goal_timeout"] == AUTO and settings.goal_timeout.auto
    assert (settings.goal_timeout.factor, settings.goal_timeout.margin) == (data["goal_timeout_factor"],
                                                                            data["goal_timeout_margin"])
    assert settings.episode_timeout_factor == data["episode_timeout_factor"]


@pytest.mark.parametrize("key, value, problem", [
    ("goal_timeout", "-1", "goal_timeout: must be positive, got -1"),
    ("goal_timeout", "later", "goal_timeout: is not a number of seconds or auto: 'later'"),
    ("goal_timeout_factor", "0.5", "goal_timeout_factor: must be >= 1.0, got 0.5"),
    ("goal_timeout_margin", "-2", "goal_timeout_margin: must be >= 0.0, got -2.0"),
    ("episode_timeout_factor", "auto", "episode_timeout_factor: expected a number, got 'auto'")])
def test_a_bad_task_config_value_is_one_line(tmp_path, key, value, problem):
    text = default_config_path("task.yaml").read_text()
    path = tmp_path / "task.yaml"
    path.write_text(re.sub(rf"^{key}: \S+", f"{key}: {value}", text, flags=re.M))
    with pytest.raises(ConfigError) as error:
        load_task_settings(path)
    assert str(error.value) == f"{path}: {problem}"


# ---------------------------------------------------------------------------------------------- the embedded executor

def two_leg_table():
    """Robots at x = 0 and x = 10, tasks at x = 2 (2 m from robot 0) and x = 30 (20 m from robot 1),
    driven at 0.2 m/s, no turns: nominal legs of 10 s and 100 s."""
    xs = [0.0, 10.0, 2.0, 30.0]
    length = np.abs(np.subtract.outer(xs, xs))
    model = TravelModel(nav_config_dir="", linear_speed=0.2, angular_speed=1.0, min_goal_time=0.1,
                        heading_lookahead=0.5)
    paths = [[np.array([(a, 0.0), (b, 0.0)]) for b in xs] for a in xs]
    return TravelTable([(x, 0.0, 0.0) for x in xs], length, np.zeros((4, 4)), length / 0.2, paths, model)


HALF_SPEED = NoiseProfile(linear_speed_scale=0.5)   # every leg takes twice its nominal time


@pytest.mark.parametrize("rule, outcomes", [
    # (reached, nav_time, failure) of robot 0 (nominal 10 s, takes 20 s) and robot 1 (100 s, takes 200 s)
    (GoalTimeout(None, factor=1.0, margin=12.0), [(True, 20.0, ""), (False, 112.0, "goal timeout")]),
    (GoalTimeout(None, factor=2.5, margin=0.0), [(True, 20.0, ""), (True, 200.0, "")]),
    (GoalTimeout(None, factor=1.5, margin=0.0), [(False, 15.0, "goal timeout"), (False, 150.0, "goal timeout")]),
    (GoalTimeout(60.0), [(True, 20.0, ""), (False, 60.0, "goal timeout")]),
])
def test_the_embedded_executor_fails_a_leg_past_its_own_timeout_and_not_one_within_it(rule, outcomes):
    executor = EmbeddedExecutor(two_leg_table(), 2, HALF_SPEED, rule)
    step = executor.start_step([0, 1], time_limit=1000.0)
    got = [(r.reached, r.nav_time, r.failure) for r in step.robots]
    assert [(reached, pytest.approx(nav), failure) for reached, nav, failure in outcomes] == got
    # Event mode: the same legs, dispatched one by one, end the same way.
    executor.reset()
    executor.dispatch(0, 0)
    executor.dispatch(1, 1)
    ends = {}
    while len(ends) < 2:
        advance = executor.advance(until=1000.0)
        ends.update({leg.robot: (leg.reached, advance.time, leg.failure) for leg in advance.legs})
    assert [(reached, pytest.approx(nav), failure) for reached, nav, failure in outcomes] == [ends[0], ends[1]]


# ---------------------------------------------------------------------------------------------- overrides

def with_episode(tmp_path, source: Path, attributes: str, name: str = "floor.xml") -> Path:
    """`source` with its <episode> element's attributes replaced; its map referred to absolutely."""
    text = source.read_text()
    text = re.sub(r"<episode [^>]*/>", f"<episode {attributes}/>", text)
    text = re.sub(r'<map file="([^"]+)"', lambda m: f'<map file="{(source.parent / m.group(1)).resolve()}"', text)
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_scenarios_goal_timeout_wins_over_the_files_and_a_command_lines_over_both(tmp_path):
    plain = make_env(with_episode(tmp_path, LAB_2R, 'timeout="120"', "plain.xml"))
    assert plain.settings.goal_timeout == load_task_settings().goal_timeout and plain.scenario.goal_timeout == AUTO
    path = with_episode(tmp_path, LAB_2R, 'timeout="120" goal_timeout="45"')
    assert load_scenario(path).goal_timeout == 45.0
    env = make_env(path)
    assert env.settings.goal_timeout.seconds == 45.0 and env.scenario.goal_timeout == 45.0
    assert make_env(path, goal_timeout="auto").settings.goal_timeout.auto
    assert make_env(LAB_2R, goal_timeout=50).settings.goal_timeout.seconds == 50.0
    # An environment built from another's scenario keeps the goal timeout in force (lookahead, replays).
    assert make_env(make_env(path, goal_timeout=70).scenario).settings.goal_timeout.seconds == 70.0
    # The ROS executors' legs get the same rule.
    assert scenario_leg_timeouts(load_scenario(path)).rule.seconds == 45.0
    assert scenario_leg_timeouts(load_scenario(path), goal_timeout="auto").rule.auto


def test_an_auto_episode_timeout_is_a_number_once_the_environment_is_built(tmp_path):
    path = with_episode(tmp_path, LAB_2R, 'timeout="auto"')
    scenario = load_scenario(path)
    assert scenario.episode_timeout is None
    env = make_env(scenario)
    table = scenario_travel_table(scenario)
    expected = auto_episode_timeout(table.nominal_time, 2, [t.service_time for t in scenario.tasks],
                                    load_task_settings().episode_timeout_factor)
    assert env.scenario.episode_timeout == expected and expected >= 10.0
    out = env.reset(seed=0)
    assert np.isfinite(out.obs).all()


@pytest.mark.parametrize("attributes, message", [
    ('timeout="120" goal_timeout="0"', "<episode>: goal_timeout must be positive, got 0"),
    ('timeout="120" goal_timeout="-3"', "<episode>: goal_timeout must be positive, got -3"),
    ('timeout="120" goal_timeout="soon"', "<episode>: goal_timeout is not a number of seconds or auto: 'soon'"),
    ('timeout="120" goal_timeout=""', "<episode>: attribute 'goal_timeout' is empty"),
    ('timeout="never"', "<episode>: timeout is not a number of seconds or auto: 'never'"),
    ('timeout="0"', "<episode>: timeout must be positive, got 0"),
    ('timeout="120" goal_timout="60"', "<episode>: unknown attribute 'goal_timout'"),
])
def test_a_bad_timeout_in_a_scenario_is_one_line_naming_file_element_and_attribute(tmp_path, attributes, message):
    path = with_episode(tmp_path, LAB_2R, attributes)
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    assert str(error.value) == f"{path}: {message}"


def test_evaluate_refuses_a_bad_timeout_in_one_line_with_exit_2(tmp_path, capsys):
    path = with_episode(tmp_path, LAB_2R, 'timeout="120" goal_timeout="-3"')
    out = tmp_path / "out.json"
    assert evaluate(["--method", "random", "--scenario", str(path), "--episodes", "1", "--quiet",
                     "--out", str(out)]) == 2
    assert capsys.readouterr().err.strip() == f"evaluate: {path}: <episode>: goal_timeout must be positive, got -3"
    for bad, problem in (("-1", "must be positive, got -1"), ("later", "is not a number of seconds or auto: 'later'")):
        assert evaluate(["--method", "random", "--scenario", str(LAB_2R), "--goal-timeout", bad, "--quiet",
                         "--out", str(out)]) == 2
        assert capsys.readouterr().err.strip() == f"evaluate: --goal-timeout: {problem}"
    assert not out.exists()


# ---------------------------------------------------------------------------------------------- a building-size floor

def corridor_floor(tmp_path) -> Path:
    """A corridor 112 m long and 3 m wide (map_saver's PGM: free 254, walls 0, 0.05 m cells)."""
    width, height = 2240, 60
    grid = np.full((height, width), 254, dtype=np.uint8)
    grid[:3, :] = grid[-3:, :] = grid[:, :3] = grid[:, -3:] = 0
    (tmp_path / "corridor.pgm").write_bytes(f"P5\n{width} {height}\n255\n".encode() + grid.tobytes())
    (tmp_path / "corridor.yaml").write_text("image: corridor.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"
                                            "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return tmp_path / "corridor.yaml"


def long_leg_scenario(tmp_path, episode: str, name: str) -> Path:
    """One robot; A1 5 m away, B1 100 m beyond it, after A1: every way to B1 has a leg of 100 m."""
    corridor_floor(tmp_path)
    path = tmp_path / f"{name}.xml"
    path.write_text(f"""<?xml version="1.0"?>
<scenario name="{name}">
  <map file="corridor.yaml"/>
  <robots>
    <robot id="tb3_0" x="1.0" y="1.5" yaw="0.0"/>
  </robots>
  <tasks>
    <task id="A1" category="A" x="6.0" y="1.5" yaw="0.0" service_time="1.0"/>
    <task id="B1" category="B" x="106.0" y="1.5" yaw="0.0"/>
  </tasks>
  <precedence>
    <edge before="A1" after="B1"/>
  </precedence>
  <episode {episode}/>
  <nav_time t_min="10.0" t_avg="200.0" t_max="700.0"/>
</scenario>
""")
    return path


def test_a_100_m_leg_refused_by_a_fixed_60_s_runs_through_evaluate_with_auto(tmp_path, capsys):
    path = long_leg_scenario(tmp_path, 'timeout="auto"', "corridor")
    table = scenario_travel_table(load_scenario(path))
    assert table.length[1, 2] > 100.0 and table.nominal_time[1, 2] > 60.0
    out = tmp_path / "auto.json"
    args = ["--method", "exact,random", "--scenario", str(path), "--episodes", "1", "--quiet", "--out", str(out)]
    # The paper's fixed rule refuses it, as every run did before.
    assert evaluate(args + ["--goal-timeout", "60"]) == 2
    assert capsys.readouterr().err.strip() == (f"evaluate: {path}: <task id=\"B1\">: no robot can reach its goal "
                                               f"(106, 1.5): every way there has a leg longer than the goal timeout "
                                               f"(60 s)")
    # config/task.yaml's auto, unedited: the reference plans it and the episodes finish it.
    assert evaluate(args) == 0
    capsys.readouterr()
    document = json.loads(out.read_text())
    assert document["goal_timeout"] == AUTO
    assert document["episode_timeout"] == auto_episode_timeout(table.nominal_time, 1, [1.0, 0.0],
                                                               load_task_settings().episode_timeout_factor)
    nominal = table.nominal_time[0, 1] + 1.0 + table.nominal_time[1, 2]
    assert document["exact"]["makespan"] == pytest.approx(nominal) and document["exact"]["proven_optimal"]
    for result in document["results"]:
        assert result["summary"]["complete_pct"] == 100.0 and result["episodes"][0]["makespan"] > 60.0
    # The scenario's own goal_timeout wins over config/task.yaml's; a command line's over both.
    fixed = long_leg_scenario(tmp_path, 'timeout="auto" goal_timeout="60"', "corridor_60")
    assert evaluate(["--method", "exact", "--scenario", str(fixed), "--episodes", "1", "--quiet",
                     "--out", str(out)]) == 2
    assert "longer than the goal timeout (60 s)" in capsys.readouterr().err
    assert evaluate(["--method", "exact", "--scenario", str(fixed), "--episodes", "1", "--quiet",
                     "--out", str(out), "--goal-timeout", "auto"]) == 0
    assert json.loads(out.read_text())["results"][0]["summary"]["complete_pct"] == 100.0


def test_the_planners_refuse_a_task_no_way_leads_to_also_with_auto(monkeypatch):
    """With auto every finite leg is feasible (the instance's goal timeout is inf), but a task with
    no path at all still has no plan: it is named as before."""
    from marl_mrta.baselines import reference
    scenario = load_scenario(LAB_2R)
    table = scenario_travel_table(scenario)
    cut = np.array(table.nominal_time)
    cut[:, scenario.n_robots + 5] = np.inf   # no way into task B2
    cut[scenario.n_robots + 5, scenario.n_robots + 5] = 0.0
    monkeypatch.setattr(reference, "scenario_travel_table", lambda s: TravelTable(
        table.node_poses, table.length, table.turn_time, cut, table.paths, table.model))
    instance = SchedulingInstance(2, 8, cut, (0.0,) * 8, scenario.predecessors, goal_timeout=math.inf)
    assert instance.unreachable_tasks() == [5]
    with pytest.raises(ScenarioError) as error:
        reference.scheduling_instance(scenario, 1.0, load_task_settings().goal_timeout)
    task = scenario.tasks[5]
    assert str(error.value) == (f"{LAB_2R}: <task id=\"{task.id}\">: no robot can reach its goal "
                                f"({task.goal.x:g}, {task.goal.y:g}): no way leads there")


def test_train_takes_the_goal_timeout_over_the_scenarios(tmp_path, capsys):
    pytest.importorskip("torch")
    from marl_mrta.apps import train
    assert train.main(["--goal-timeout", "-1", "--init", "none", "--out", str(tmp_path / "run")]) == 2
    assert capsys.readouterr().err.strip() == "train: --goal-timeout: must be positive, got -1"
    assert not (tmp_path / "run").exists()
    scenario = with_episode(tmp_path, LAB_2R, 'timeout="120" goal_timeout="45"')
    for given, seconds in ((None, 45.0), ("70", 70.0)):
        args = train.build_parser().parse_args(["--init", "none"] + (["--goal-timeout", given] if given else []))
        backend = train._backend(args, train._settings(args, "tuned"), 0, str(scenario))
        assert backend["make_env"]().settings.goal_timeout.seconds == seconds
        assert backend["scenario"] == str(scenario)   # the run keeps naming the file
