"""The embedded travel times come from navigation's own planner: the table's paths are the
paths libmarl_mrta_travel.so plans (navfn on move_base's global costmap), the turns follow the
path's direction over `heading_lookahead`, and a bad navigation directory is one line."""
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import default_config_path, package_root
from marl_mrta.env.embedded import EmbeddedExecutor
from marl_mrta.env.factory import scenario_travel_table
from marl_mrta.env.settings import load_embedded_settings
from marl_mrta.model.navfn_paths import LIBRARY_NAME, plan_all_pairs
from marl_mrta.model.scenario import load_scenario
from marl_mrta.model.travel import build_travel_table, nominal_travel_table, path_heading, scenario_poses

LAB_2R = package_root() / "scenarios" / "lab_2r.xml"


def test_the_tables_paths_are_navfns_own_from_the_robots_pose_to_the_goal():
    scenario = load_scenario(LAB_2R)
    table = scenario_travel_table(scenario)
    poses = scenario_poses(scenario)
    navfn, planner_speed = plan_all_pairs(str(scenario.map_path), str(default_config_path("nav")), poses)
    assert planner_speed == table.model.linear_speed == 0.22   # TurtleBot3's DWA drives at the Burger's top speed
    for a in range(len(poses)):
        for b in range(len(poses)):
            if a == b:
                continue
            path = table.paths[a][b]
            assert tuple(path[0]) == pytest.approx(poses[a][:2])        # the pose, not its cell's corner
            assert tuple(path[-1]) == pytest.approx(poses[b][:2])
            np.testing.assert_array_equal(path[1:len(navfn[a][b])], navfn[a][b][1:])
            assert table.length[a, b] == pytest.approx(np.hypot(*np.diff(path, axis=0).T).sum())
            assert table.nominal_time[a, b] >= table.length[a, b] / table.model.linear_speed


def test_turns_are_to_the_paths_direction_over_the_lookahead():
    # A cell's corner 0.05 m off the line, then straight along +x: the first segment points at
    # 45 degrees, the path's direction over 0.5 m at about 6.
    points = np.array([(0.0, 0.0), (0.05, 0.05), (0.55, 0.05), (2.0, 0.05)])
    assert path_heading(points, 0.01) == pytest.approx(math.pi / 4)
    assert path_heading(points, 0.5) == pytest.approx(math.atan2(0.05, 0.55))
    assert path_heading(points, 10.0) == pytest.approx(math.atan2(0.05, 2.0))   # shorter path: its end


def test_a_navigation_directory_without_the_costmap_file_is_one_line(tmp_path):
    model = load_embedded_settings(nav_config_dir=tmp_path).travel
    with pytest.raises(ConfigError) as error:
        nominal_travel_table(load_scenario(LAB_2R), model)
    text = str(error.value)
    assert "\n" not in text and text.startswith("travel planning on ")
    assert "costmap_common_params_burger.yaml: cannot be read" in text


def test_along_each_path_ends_at_its_length():
    # The proximity check places robots by distance along their paths (env/embedded.py).
    table = scenario_travel_table(load_scenario(LAB_2R))
    for a in range(table.n_nodes):
        for b in range(table.n_nodes):
            along = table.path_along[a][b]
            assert len(along) == len(table.paths[a][b]) and along[0] == 0.0
            assert np.all(np.diff(along) >= 0.0) and along[-1] == pytest.approx(table.length[a, b])


def test_the_distances_along_the_paths_are_measured_only_for_the_proximity_check():
    scenario = load_scenario(LAB_2R)
    settings = load_embedded_settings()
    table = build_travel_table(str(scenario.map_path), scenario_poses(scenario), settings.travel)   # not cached
    goals = list(range(scenario.n_robots))
    EmbeddedExecutor(table, scenario.n_robots, settings.profile("ideal"), 100.0).start_step(goals, 100.0)
    assert "path_along" not in vars(table)
    noisy = settings.profile("measured_tb3")
    assert noisy.proximity_collisions
    EmbeddedExecutor(table, scenario.n_robots, noisy, 100.0, seed=0,
                     collision_distance=settings.collision_distance).start_step(goals, 100.0)
    assert "path_along" in vars(table)


def _plan_in_a_shell(environment):
    """plan_all_pairs in a fresh interpreter (the dynamic loader reads LD_LIBRARY_PATH at start)."""
    script = ("import sys\n"
              "from marl_mrta.common.paths import default_config_path\n"
              "from marl_mrta.model.navfn_paths import plan_all_pairs\n"
              "from marl_mrta.model.scenario import load_scenario\n"
              "from marl_mrta.model.travel import scenario_poses\n"
              f"s = load_scenario({str(LAB_2R)!r})\n"
              "paths = plan_all_pairs(str(s.map_path), str(default_config_path('nav')), scenario_poses(s)).paths\n"
              "print(len(paths[0][1]))\n")
    return subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True,
                          timeout=120)


def test_the_library_is_found_through_the_catkin_prefixes_and_missing_is_one_line():
    library_dirs = [d for d in os.environ.get("LD_LIBRARY_PATH", "").split(os.pathsep)
                    if d and (Path(d) / LIBRARY_NAME).exists()]
    if not library_dirs:
        pytest.skip(f"{LIBRARY_NAME} is not on LD_LIBRARY_PATH (source the workspace's setup.bash)")
    prefix = str(Path(library_dirs[0]).parent)
    kept = os.pathsep.join(d for d in os.environ["LD_LIBRARY_PATH"].split(os.pathsep) if d not in library_dirs)
    found = _plan_in_a_shell({**os.environ, "LD_LIBRARY_PATH": kept, "CMAKE_PREFIX_PATH": prefix})
    assert found.returncode == 0, found.stderr
    assert int(found.stdout) > 2   # a planned path, not the straight line
    missing = _plan_in_a_shell({**os.environ, "LD_LIBRARY_PATH": kept, "CMAKE_PREFIX_PATH": ""})
    assert missing.returncode != 0
    last = missing.stderr.strip().splitlines()[-1]
    assert last.endswith(f"{LIBRARY_NAME} not found: build the package (make build) and source its "
                         "workspace's devel/setup.bash")
