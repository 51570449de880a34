"""Live variants of a scenario: tasks released over time, robots lost (ROS-free).

A variant keeps the scenario's floor, robots and tasks and adds what a live fleet meets
(docs/reference/scenario_format.md, `release` and `<faults>`):
- releases: a share of the tasks is known at the start; the others are released one at a time, in
  a random order that never releases a task before one of its predecessors, at the arrival times
  of a Poisson process whose rate puts the expected last release `span` s after the start;
- faults: robots drawn at random leave at times drawn uniformly from a window.
Everything is drawn from one seed. apps/bench_fleet.py measures the live fleet on them;
write_variant() saves one as a scenario file.
"""
from __future__ import annotations

import dataclasses
import random
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import List, Sequence, Tuple

from marl_mrta.model.scenario import FaultSpec, Scenario


def release_order(predecessors: Sequence[Sequence[int]], rng: random.Random) -> List[int]:
    """A random order of the tasks in which every task comes after its predecessors."""
    left = set(range(len(predecessors)))
    order: List[int] = []
    while left:
        ready = sorted(j for j in left if all(p not in left for p in predecessors[j]))
        task = rng.choice(ready)
        order.append(task)
        left.remove(task)
    return order


def live_variant(scenario: Scenario, seed: int, known_share: float, span: float, faults: int = 0,
                 fault_window: Tuple[float, float] = (0.0, 0.0), name_suffix: str = "") -> Scenario:
    """The scenario with releases (`known_share` of its tasks at 0, the rest over about `span` s)
    and `faults` robots leaving within `fault_window` (s); see the module docstring."""
    if not 0.0 <= known_share <= 1.0:
        raise ValueError(f"known_share {known_share:g} is not within [0, 1]")
    if faults >= scenario.n_robots:
        raise ValueError(f"{faults} faults would leave no robot of {scenario.n_robots}")
    rng = random.Random(seed)
    order = release_order(scenario.predecessors, rng)
    known = round(known_share * scenario.n_tasks)
    later = order[known:]
    release = [0.0] * scenario.n_tasks
    if later:
        rate = len(later) / span if span > 0 else float("inf")
        at = 0.0
        for task in later:
            at += rng.expovariate(rate) if rate != float("inf") else 0.0
            release[task] = round(at, 2)
    tasks = tuple(dataclasses.replace(t, release=release[j]) for j, t in enumerate(scenario.tasks))
    lost = sorted(rng.sample(range(scenario.n_robots), faults))
    fault_specs = tuple(sorted((FaultSpec(r, round(rng.uniform(*fault_window), 2)) for r in lost),
                               key=lambda f: (f.at, f.robot)))
    return dataclasses.replace(scenario, name=scenario.name + name_suffix, tasks=tasks, faults=fault_specs)


def write_variant(scenario: Scenario, path: Path) -> Path:
    """The variant as a scenario file: its source file with the releases and faults added (the map
    and navigation directory given as absolute paths, so the file may live anywhere)."""
    tree = ET.parse(str(scenario.source))
    root = tree.getroot()
    root.set("name", scenario.name)
    root.find("map").set("file", str(Path(scenario.map_path).resolve()))
    robots = root.find("robots")
    if scenario.navigation_dir is not None:
        robots.set("navigation", str(scenario.navigation_dir))
    for element, task in zip(root.find("tasks"), scenario.tasks):
        if task.release > 0.0:
            element.set("release", f"{task.release:g}")
        elif "release" in element.attrib:
            del element.attrib["release"]
    for old in root.findall("faults"):
        root.remove(old)
    if scenario.faults:
        faults = ET.SubElement(root, "faults")
        for fault in scenario.faults:
            ET.SubElement(faults, "fault", {"robot": scenario.robots[fault.robot].id, "at": f"{fault.at:g}"})
    _indent(root)
    path.parent.mkdir(parents=True, exist_ok=True)
    tree.write(str(path), encoding="unicode", xml_declaration=True)
    return path


def _indent(element: ET.Element, level: int = 0) -> None:
    """Two spaces per level (ElementTree.indent is Python 3.9's; Noetic runs 3.8)."""
    children = list(element)
    if not children:
        return
    inner = "\n" + "  " * (level + 1)
    element.text = inner
    for child in children:
        _indent(child, level + 1)
        child.tail = inner
    children[-1].tail = "\n" + "  " * level
