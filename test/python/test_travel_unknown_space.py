"""Unknown space in the travel times is what navigation's global costmap makes of it, with the
scenario's own navigation files (costmap_2d's track_unknown_space, navfn's allow_unknown): with
TurtleBot3's files, which leave track_unknown_space unset, unknown cells are free (the obstacle
layer writes them so) and a leg crosses them; with track_unknown_space: true they stay unknown,
which navfn crosses only at a high cost (allow_unknown) or never. The leg's time is that plan's.
test/gtest/nav/test_travel.cpp holds the paths to move_base's own plan; stock move_base's
make_plan takes the same way on this map in each case (through the band, or round it)."""
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.common.paths import default_config_path
from marl_mrta.env.settings import load_embedded_settings
from marl_mrta.model.navfn_paths import plan_all_pairs
from marl_mrta.model.occupancy_map import FREE, OCCUPIED, UNKNOWN, MapOrigin, OccupancyMap, load_map, save_map
from marl_mrta.model.scenario import load_scenario
from marl_mrta.model.travel import nominal_travel_table, scenario_poses

START, GOAL = (1.0, 1.6), (5.0, 1.6)

SCENARIO = """<?xml version="1.0"?>
<scenario name="unknown_band">
  <map file="band.yaml"/>
  <robots navigation="{navigation}">
    <robot id="tb3_0" x="{start[0]}" y="{start[1]}" yaw="0.0"/>
  </robots>
  <tasks>
    <task id="A1" category="A" x="{goal[0]}" y="{goal[1]}" yaw="0.0"/>
  </tasks>
  <episode timeout="120"/>
  <nav_time t_min="5.0" t_avg="20.0" t_max="40.0"/>
</scenario>
"""


def band_map(folder: Path) -> Path:
    """A 6 m x 4 m room; between START and GOAL a band of unknown cells 0.4 m wide, from the
    floor to 2.4 m, free above it."""
    grid = np.full((80, 120), FREE, dtype=np.int8)
    grid[[0, -1], :] = OCCUPIED
    grid[:, [0, -1]] = OCCUPIED
    grid[1:48, 56:64] = UNKNOWN
    path = folder / "band.yaml"
    save_map(OccupancyMap(grid, 0.05, MapOrigin(0.0, 0.0, 0.0)), path)
    return path


def navigation(folder: Path, name: str, costmap: str = "", navfn: str = "") -> Path:
    """config/nav copied, as a user copies it for a floor, with lines added to two of its files."""
    target = folder / name
    shutil.copytree(default_config_path("nav"), target)
    with (target / "costmap_common_params_burger.yaml").open("a") as out:
        out.write("\n" + costmap)
    with (target / "navfn_params.yaml").open("a") as out:
        out.write("\n" + navfn)
    return target


def unknown_cells_on(path: np.ndarray, grid_map: OccupancyMap) -> int:
    cols, rows, inside = grid_map.world_to_cells(path[:, 0], path[:, 1])
    return int((grid_map.grid[rows[inside], cols[inside]] == UNKNOWN).sum())


def test_a_leg_through_unknown_space_follows_track_unknown_space(tmp_path):
    grid_map = load_map(band_map(tmp_path))
    variants = {
        "as_shipped": navigation(tmp_path, "as_shipped"),
        "tracked": navigation(tmp_path, "tracked", costmap="track_unknown_space: true\n"),
        "tracked_not_allowed": navigation(tmp_path, "tracked_not_allowed", costmap="track_unknown_space: true\n",
                                          navfn="NavfnROS:\n  allow_unknown: false\n"),
        "untracked_not_allowed": navigation(tmp_path, "untracked_not_allowed", costmap="track_unknown_space: false\n",
                                            navfn="NavfnROS:\n  allow_unknown: false\n"),
    }
    model = load_embedded_settings().travel
    legs = {}
    for name, folder in variants.items():
        scenario_file = tmp_path / f"{name}.xml"
        scenario_file.write_text(SCENARIO.format(navigation=folder.name, start=START, goal=GOAL))
        scenario = load_scenario(scenario_file)
        assert scenario.navigation_dir == folder.resolve()
        table = nominal_travel_table(scenario, model)
        # The leg is navigation's plan with the scenario's files, and its time that plan's.
        navfn = plan_all_pairs(str(scenario.map_path), str(folder), scenario_poses(scenario)).paths[0][1]
        np.testing.assert_array_equal(table.paths[0][1][1:len(navfn)], navfn[1:])
        assert table.nominal_time[0, 1] == pytest.approx(
            max(table.turn_time[0, 1] + table.length[0, 1] / table.model.linear_speed, model.min_goal_time))
        legs[name] = (table.nominal_time[0, 1], table.length[0, 1], unknown_cells_on(table.paths[0][1], grid_map))

    straight = math.dist(START, GOAL)
    # TurtleBot3's files: unknown space is free to the global planner, the leg goes straight through.
    time, length, unknown = legs["as_shipped"]
    assert unknown > 0 and length < straight + 0.1
    assert legs["untracked_not_allowed"] == legs["as_shipped"]   # nothing unknown is left for navfn to refuse
    # Tracked: unknown costs navfn as much as it can (allow_unknown) or is an obstacle; either way
    # the planner goes round the band here, and the leg takes longer.
    for name in ("tracked", "tracked_not_allowed"):
        tracked_time, tracked_length, tracked_unknown = legs[name]
        assert tracked_unknown == 0, name
        assert tracked_length > length + 0.3 and tracked_time > time, name


def test_a_navigation_file_edited_in_place_is_planned_anew(tmp_path):
    """The tables are cached per process; an edited parameter file (or image) is a new table."""
    band_map(tmp_path)
    folder = navigation(tmp_path, "floor_nav")
    scenario_file = tmp_path / "floor.xml"
    scenario_file.write_text(SCENARIO.format(navigation=folder.name, start=START, goal=GOAL))
    model = load_embedded_settings().travel
    before = nominal_travel_table(load_scenario(scenario_file), model).length[0, 1]
    with (folder / "costmap_common_params_burger.yaml").open("a") as out:
        out.write("track_unknown_space: true\n")
    after = nominal_travel_table(load_scenario(scenario_file), model).length[0, 1]
    assert after > before + 0.3
