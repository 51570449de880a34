"""The scenario generator: seeded (same seed, same files), every scenario a valid scenario file
(the loader's validation) with its poses apart and clear of obstacles and an acyclic staged
precedence; its command line; and over generated scenarios with chains, forks and joins, every
method (random, GA, auction, the reference's plan) completes every episode through the
embedded environment, the plans logic-consistently and as long as planned."""
import math
import os
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from marl_mrta.apps.train_generalist import generated_scenarios
from marl_mrta.baselines.auction import solve_auction
from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.random_policy import RandomPolicy
from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.env.factory import make_env
from marl_mrta.env.settings import load_embedded_settings
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.evaluation.policies import PlanPolicy
from marl_mrta.model.generator import (DAG_KINDS, DEFAULT_MAX_LEG, LAYOUTS, GeneratorError, ScenarioRequest,
                                       generate_scenario)
from marl_mrta.model.occupancy_map import FREE, OCCUPIED, UNKNOWN, MapOrigin, OccupancyMap, save_map
from marl_mrta.model.scenario import footprint_radius, load_scenario
from marl_mrta.model.travel import nominal_travel_table

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def travel_model():
    return load_embedded_settings().travel


def test_the_same_seed_gives_the_same_files(tmp_path, travel_model):
    request = ScenarioRequest(n_robots=3, n_tasks=7, layout="rooms", name="same")
    generate_scenario(request, 5, tmp_path / "a", travel_model)
    generate_scenario(request, 5, tmp_path / "b", travel_model)
    generate_scenario(request, 6, tmp_path / "c", travel_model)
    for name in ("same.xml", "maps/same.yaml", "maps/same.pgm"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    assert (tmp_path / "a" / "same.xml").read_text() != (tmp_path / "c" / "same.xml").read_text()


@pytest.mark.parametrize("layout", LAYOUTS + ("shipped", "lab"))
@pytest.mark.parametrize("dag", DAG_KINDS)
def test_generated_scenarios_are_valid_files_with_poses_apart_and_clear(tmp_path, layout, dag):
    request = ScenarioRequest(n_robots=4, n_tasks=9, layout=layout, dag=dag, stages=3, name="s")
    scenario = generate_scenario(request, 1, tmp_path)
    assert load_scenario(scenario.source) == scenario          # the file is what was loaded
    assert (scenario.n_robots, scenario.n_tasks) == (4, 9)
    poses = [r.start for r in scenario.robots] + [t.goal for t in scenario.tasks]
    assert min(math.hypot(a.x - b.x, a.y - b.y) for i, a in enumerate(poses) for b in poses[:i]) >= request.spacing - 1e-9
    grid_map = scenario.load_map()
    clearance = ndimage.distance_transform_edt(grid_map.grid == FREE) * grid_map.resolution
    for pose in poses:
        cell = grid_map.world_to_cell(pose.x, pose.y)
        assert clearance[cell.row, cell.col] >= request.clearance
    stage = {t.category for t in scenario.tasks}
    assert stage == {"A", "B", "C"}
    for j, task in enumerate(scenario.tasks):
        before = {scenario.tasks[p].category for p in scenario.predecessors[j]}
        assert before == (set() if task.category == "A" else {chr(ord(task.category) - 1)})
        if dag == "chains":
            assert len(scenario.predecessors[j]) <= 1
        if dag == "joins" and task.category != "A":
            assert len(scenario.predecessors[j]) == 2
    assert {t.service_time for t in scenario.tasks} <= set(request.service_times)


def test_requests_out_of_range_are_one_line_errors(tmp_path):
    for request, message in [(ScenarioRequest(n_robots=17), "robots: 17 is not in 2..16"),
                             (ScenarioRequest(n_tasks=33), "tasks: 33 is not in 4..32"),
                             (ScenarioRequest(layout="maze"), "layout: 'maze' is not one of"),
                             (ScenarioRequest(spacing=0.1), "spacing: 0.1 m is below a robot's footprint")]:
        with pytest.raises(GeneratorError, match=message):
            generate_scenario(request, 0, tmp_path)
    assert footprint_radius() == pytest.approx(0.105)


def test_command_line_writes_the_scenarios(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    script = str(ROOT / "scripts" / "generate_scenarios")
    result = subprocess.run([sys.executable, script, str(tmp_path / "out"), "--count", "3", "--seed", "2",
                             "--robots", "3", "--tasks", "6"], capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    written = sorted((tmp_path / "out").glob("*.xml"))
    assert [p.name for p in written] == ["gen_000.xml", "gen_001.xml", "gen_002.xml"]
    assert all((load_scenario(p).n_robots, load_scenario(p).n_tasks) == (3, 6) for p in written)
    # The longest leg kept is the generator's own 60 s (what config/task.yaml's fixed goal timeout
    # gave it), not the goal timeout (auto): the same seeds draw the same files as before.
    assert all("max_leg=60.0," in p.read_text() for p in written)
    bad = subprocess.run([sys.executable, script, str(tmp_path / "bad"), "--robots", "40"], capture_output=True,
                         text=True, env=env, timeout=120)
    assert bad.returncode == 2 and bad.stderr.strip() == "generate_scenarios: robots: 40 is not in 2..16"
    no_nav = subprocess.run([sys.executable, script, str(tmp_path / "bad"), "--navigation", str(tmp_path / "none")],
                            capture_output=True, text=True, env=env, timeout=120)
    assert no_nav.returncode == 2
    assert no_nav.stderr.strip() == f"generate_scenarios: --navigation: {tmp_path / 'none'} is not a directory"


def test_a_requests_navigation_files_go_into_the_scenario_and_time_its_legs(tmp_path, travel_model):
    """The same draw with a lab's slower navigation files: the same poses, the files named in
    <robots navigation>, and the timeout and r_nav thresholds from the slower legs."""
    slow = tmp_path / "nav_slow"
    shutil.copytree(ROOT / "config" / "nav", slow)
    dwa = slow / "dwa_local_planner_params_burger.yaml"
    dwa.write_text(dwa.read_text().replace("max_vel_x: 0.22", "max_vel_x: 0.11"))
    request = ScenarioRequest(n_robots=3, n_tasks=6, layout="pillars", name="nav")
    plain = generate_scenario(request, 7, tmp_path / "plain", travel_model)
    own = generate_scenario(replace(request, navigation=str(slow)), 7, tmp_path / "own", travel_model)
    assert plain.navigation_dir is None and own.navigation_dir == slow
    assert [r.start for r in own.robots] == [r.start for r in plain.robots]
    assert [t.goal for t in own.tasks] == [t.goal for t in plain.tasks]
    assert own.nav_thresholds.t_avg > 1.5 * plain.nav_thresholds.t_avg
    assert own.episode_timeout > plain.episode_timeout


@pytest.fixture(scope="module")
def generated(tmp_path_factory, travel_model):
    """Small scenarios of every DAG kind (legs within the default --max-leg, as the command line makes them)."""
    base = ScenarioRequest(max_leg=DEFAULT_MAX_LEG, name="done")
    scenarios = []
    for k, dag in enumerate(DAG_KINDS * 2):
        request = replace(base, n_robots=2 + k % 4, n_tasks=5 + k, dag=dag, stages=2 + k % 3,
                          layout=(LAYOUTS + ("lab",))[k % 4], width=7.0, height=5.0, name=f"done_{k}")
        scenarios.append(generate_scenario(request, 40 + k, tmp_path_factory.mktemp("generated"), travel_model))
    return scenarios


@pytest.mark.slow
def test_every_method_completes_every_generated_scenario(generated):
    settings = load_baseline_settings().with_cpsat(time_limit=1.0)
    for scenario in generated:
        env = make_env(scenario, seed=0)
        instance = scheduling_instance(scenario, env.settings.min_step, env.settings.goal_timeout)
        plans = [solve_ga(instance, replace(settings.ga, max_evaluations=1500), seed=0), solve_auction(instance)]
        plans.append(solve_reference(instance, settings, plans).plan)
        for plan in plans:
            record = run_episodes(env, PlanPolicy(plan, env.n_agents, env.n_tasks), 1, 0)[0]
            assert record.complete and record.logic_consistent, (scenario.name, plan.method)
            assert record.makespan == pytest.approx(plan.makespan, abs=1e-9), (scenario.name, plan.method)
        for record in run_episodes(env, RandomPolicy(env.n_agents, env.n_tasks, "unfinished", seed=0), 5, 0):
            assert record.complete, (scenario.name, "random")


def _long_floor(directory: Path, yaw: float = 0.0) -> Path:
    """A floor of one's own as SLAM leaves it: a 30 x 3 m hall amid unknown space, with a closed
    1 x 1 m box in it whose inside no robot reaches; end to end its legs are far beyond the goal
    timeout (about 30 m at 0.22 m/s). `yaw`: the map's origin yaw."""
    cols, rows = 640, 100
    grid = np.full((rows, cols), UNKNOWN, dtype=np.int8)
    grid[20:80, 10:630] = OCCUPIED
    grid[22:78, 12:628] = FREE
    grid[40:62, 300:322] = OCCUPIED           # the box: its inside stays free but unreachable
    grid[43:59, 303:319] = FREE
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "long_floor.yaml"
    save_map(OccupancyMap(grid, 0.05, MapOrigin(-2.0, -1.0, yaw)), path)
    return path


def test_a_floor_of_ones_own_gives_reachable_poses_within_the_goal_timeout(tmp_path, travel_model):
    floor = _long_floor(tmp_path / "floor")
    request = ScenarioRequest(n_robots=3, n_tasks=7, layout=str(floor), max_leg=DEFAULT_MAX_LEG,
                              name="own")
    scenario = generate_scenario(request, 3, tmp_path / "out", travel_model)
    assert scenario.map_path == floor.resolve()
    assert f'<map file="{floor.resolve()}"/>' in scenario.source.read_text()
    grid_map = scenario.load_map()
    clearance = ndimage.distance_transform_edt(grid_map.grid == FREE) * grid_map.resolution
    for pose in [r.start for r in scenario.robots] + [t.goal for t in scenario.tasks]:
        cell = grid_map.world_to_cell(pose.x, pose.y)
        assert clearance[cell.row, cell.col] >= request.clearance
        assert not (300 <= cell.col < 322 and 40 <= cell.row < 62), pose   # not in the box (grid row 0: lowest y)
    legs = nominal_travel_table(scenario, travel_model).nominal_time
    assert float(legs[:, scenario.n_robots:].max()) <= request.max_leg
    # The draw follows the floor's name and the seed, not where the file lies.
    moved = _long_floor(tmp_path / "elsewhere")
    again = generate_scenario(replace(request, layout=str(moved)), 3, tmp_path / "again", travel_model)
    assert [t.goal for t in again.tasks] == [t.goal for t in scenario.tasks]


def test_a_floor_that_is_no_map_is_one_line(tmp_path):
    with pytest.raises(GeneratorError, match=r"^layout: .*missing\.yaml: cannot read"):
        generate_scenario(ScenarioRequest(layout=str(tmp_path / "missing.yaml")), 0, tmp_path)
    # Navigation (stock and built-in) ignores a map's origin yaw; the scenario would not.
    rotated = _long_floor(tmp_path / "rotated", yaw=math.pi / 2)
    with pytest.raises(GeneratorError, match=r"^layout: .*long_floor\.yaml: origin: yaw 1\.5708 rad is not 0: "
                                             r"move_base's costmaps and amcl ignore a map's origin yaw"):
        generate_scenario(ScenarioRequest(layout=str(rotated)), 0, tmp_path)
    with pytest.raises(GeneratorError, match=r"^layout: '.*floor\.png' is not one of .* or a map YAML file$"):
        generate_scenario(ScenarioRequest(layout=str(tmp_path / "floor.png")), 0, tmp_path)


def test_training_and_benchmark_scenarios_take_a_floor_of_ones_own(tmp_path):
    floor = _long_floor(tmp_path / "floor")
    scenarios = generated_scenarios(3, 5, tmp_path / "out", "test", (2, 3), (4, 6), str(floor))
    assert [s.map_path for s in scenarios] == [floor.resolve()] * 3
    assert all(2 <= s.n_robots <= 3 and 4 <= s.n_tasks <= 6 for s in scenarios)
