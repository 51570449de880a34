"""The rviz configuration for any team: rviz/marl_mrta.rviz holds one robot's display group
(tb3_0: model, scan, odometry) and one task-marker display; this module repeats them for every
robot of every arena (common/robot_names.py), each robot in a colour of its own."""
from __future__ import annotations

import copy
from pathlib import Path
from typing import Any, Dict, Sequence

import yaml

from marl_mrta.common.robot_names import arena_namespaces

TEMPLATE_ROBOT = "tb3_0"
TASK_MARKERS = "Tasks"
#: Colours of the robots' scans and odometry arrows, in turn (rviz "R; G; B"): those of
#: rviz/marl_mrta.rviz's four groups first, then more; none blue, the robot model's colour.
COLOURS = ("239; 41; 41", "245; 121; 0", "78; 154; 6", "173; 127; 168", "193; 125; 17", "6; 152; 154",
           "204; 0; 102", "117; 80; 123")


def _retarget(value: Any, old: str, new: str) -> Any:
    """Every string of a display tree with the template robot's name replaced."""
    if isinstance(value, dict):
        return {k: _retarget(v, old, new) for k, v in value.items()}
    if isinstance(value, list):
        return [_retarget(v, old, new) for v in value]
    return value.replace(old, new) if isinstance(value, str) else value


def _recolour(group: Dict[str, Any], colour: str) -> None:
    for display in group.get("Displays", []):
        if "Color" in display:
            display["Color"] = colour
        if isinstance(display.get("Shape"), dict) and "Color" in display["Shape"]:
            display["Shape"]["Color"] = colour


def team_config(template: Dict[str, Any], namespaces: Sequence[str], arenas: int) -> Dict[str, Any]:
    """The template with one robot group per namespace and one task-marker display per arena."""
    config = copy.deepcopy(template)
    displays = config["Visualization Manager"]["Displays"]
    robot_group = next(d for d in displays if d.get("Class") == "rviz/Group" and d.get("Name") == TEMPLATE_ROBOT)
    markers = next(d for d in displays if d.get("Class") == "rviz/MarkerArray" and d.get("Name") == TASK_MARKERS)
    # The template's own robot groups (tb3_0 ... tb3_3) give way to the team's.
    kept = [d for d in displays if not (d.get("Class") == "rviz/Group" and str(d.get("Name", "")).startswith("tb3_"))
            and d is not markers]
    groups = []
    for index, ns in enumerate(namespaces):
        group = _retarget(robot_group, TEMPLATE_ROBOT, ns)
        group["Name"] = ns
        _recolour(group, COLOURS[index % len(COLOURS)])
        groups.append(group)
    arena_markers = []
    for k in range(arenas):
        display = copy.deepcopy(markers)
        if arenas > 1:
            display["Name"] = f"{TASK_MARKERS} arena_{k}"
            display["Marker Topic"] = f"/arena_{k}{markers['Marker Topic']}"
        arena_markers.append(display)
    first_robot = displays.index(robot_group)
    config["Visualization Manager"]["Displays"] = kept[:first_robot] + groups + arena_markers + kept[first_robot:]
    return config


def write_team_config(template_path: Path, out: Path, robot_names: Sequence[str], arenas: int) -> Path:
    template = yaml.safe_load(Path(template_path).read_text())
    out.parent.mkdir(parents=True, exist_ok=True)
    config = team_config(template, arena_namespaces(robot_names, arenas), arenas)
    out.write_text(yaml.safe_dump(config, sort_keys=False))
    return out
