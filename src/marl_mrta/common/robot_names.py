"""Robot namespaces. A scenario's robot ids are its robots' ROS namespaces, in simulation as on
the robots (tasks.launch hands them to the simulator). Where no names are given (sim.launch
alone, generated scenarios) robot i is tb3_i, TurtleBot3's multi_robot_name convention; with
several arenas robot r of arena k is arena_k/r (docs/reference/nodes_sim_nav.md)."""
from __future__ import annotations

from typing import List, Sequence, Union


def default_robot_names(count: int) -> List[str]:
    return [f"tb3_{i}" for i in range(count)]


def name_list(value: Union[str, Sequence[str], None]) -> List[str]:
    """Names from a parameter: a list, or one string separated by spaces or commas (a launch argument)."""
    if value is None:
        return []
    if isinstance(value, str):
        return value.replace(",", " ").split()
    return [str(name) for name in value]


def arena_namespaces(names: Sequence[str], arenas: int) -> List[str]:
    """Every robot's namespace, arena by arena: the names themselves with one arena."""
    if arenas == 1:
        return list(names)
    return [f"arena_{k}/{name}" for k in range(arenas) for name in names]
