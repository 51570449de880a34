"""What launch/tasks.launch takes from a scenario: robot count, map, start poses; a broken
scenario gives values that start a valid graph (the manager then reports the problem)."""
from pathlib import Path

import yaml

from marl_mrta.ros.launch_args import scenario_value
from marl_mrta.model.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]


def test_values_of_the_lab_scenarios():
    for name, robots in (("lab_2r", 2), ("lab_3r", 3), ("lab_4r", 4)):
        path = str(ROOT / "scenarios" / f"{name}.xml")
        scenario = load_scenario(path)
        assert scenario_value(path, "robots") == robots
        assert Path(scenario_value(path, "map")) == (ROOT / "maps" / "lab.yaml").resolve()
        poses = yaml.safe_load(scenario_value(path, "start_poses"))
        assert poses == [[r.start.x, r.start.y, r.start.yaw] for r in scenario.robots]


def test_a_broken_scenario_still_gives_a_startable_graph():
    bad = str(ROOT / "test" / "data" / "scenarios" / "precedence_cycle.xml")
    assert scenario_value(bad, "robots") == 1
    assert Path(scenario_value(bad, "map")).is_file()
    assert len(yaml.safe_load(scenario_value(bad, "start_poses"))) == 1
