"""Values launch/tasks.launch takes from a scenario file, so that the simulator runs the
scenario's map and robots at its start poses (called from a launch file's $(eval)).

A scenario that cannot be loaded gives values that start a valid graph (the lab, one robot):
the task manager then reports the scenario's problem in its one-line FATAL and ends the launch.
"""
from __future__ import annotations

from typing import Union

from marl_mrta.model.scenario import ScenarioError, load_scenario
from marl_mrta.common.paths import package_root


def scenario_value(path: str, key: str) -> Union[int, str]:
    """key: `robots` (count), `map` (map_server YAML), `start_poses` (YAML list of [x, y, yaw])."""
    try:
        scenario = load_scenario(path)
    except ScenarioError:
        fallback = {"robots": 1, "map": str(package_root() / "maps" / "lab.yaml"), "start_poses": "[[0.5, 0.5, 0.0]]"}
        return fallback[key]
    if key == "robots":
        return scenario.n_robots
    if key == "map":
        return str(scenario.map_path.resolve())
    if key == "start_poses":
        return "[" + ", ".join(f"[{r.start.x!r}, {r.start.y!r}, {r.start.yaw!r}]" for r in scenario.robots) + "]"
    raise KeyError(f"scenario_value: unknown key {key!r} (robots, map, start_poses)")
