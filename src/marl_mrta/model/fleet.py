"""The order in which a real fleet drives back to its start poses between episodes (ROS-free).

Robots driving at once meet on their way, and a robot's lidar then puts the other robot into its
own footprint's cells: move_base discards every velocity and runs its recovery behaviors
(docs/guide/real_robots.md). One at a time, each robot drives among robots that stand still, which
its costmaps see as obstacles and plan round. A robot waits while another robot still stands on
its start pose (their footprints would overlap there: model/scenario.footprint_spacing); robots
that block each other's start poses in a cycle drive together, as the last group.
"""
from __future__ import annotations

import math
from typing import List, Sequence, Tuple

Point = Tuple[float, float]


def reset_groups(positions: Sequence[Point], starts: Sequence[Point], spacing: float) -> List[List[int]]:
    """Robots (indices) in the groups that drive to their start poses one group after another:
    single robots, each the first by index whose start pose no robot still to drive stands on
    (centres closer than `spacing`, footprint_spacing), then, if any remain, all of them together."""
    waiting = list(range(len(starts)))
    groups: List[List[int]] = []
    while waiting:
        free = next((r for r in waiting
                     if all(math.dist(positions[other], starts[r]) >= spacing
                            for other in waiting if other != r)), None)
        if free is None:
            groups.append(waiting)
            break
        groups.append([free])
        waiting = [r for r in waiting if r != free]
    return groups
