"""What rviz shows of a live fleet (ros/markers.py draws it), ROS-free: per task a colour, a label,
a ring for a task submitted during the episode and a cross for a cancelled one; per robot that
left, a cross where it stands and why; precedence arrows among the tasks still in the schedule.

Colours: grey open or ready (pending), orange taken (a robot drives to, holds at or serves it),
green finished, violet orphaned (back in the pool after its robot left, not taken again yet), dark
cancelled. Tasks not released yet are not shown (ros/fleet_status.py does not list them).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Tuple

from marl_mrta.ros.fleet_status import CANCELLED, FINISHED, FleetSnapshot, TaskStatus

#: Colour names (ros/markers.py maps them to RGBA).
PENDING, ASSIGNED, DONE, WRONG_ORDER, ORPHANED, CANCELLED_COLOUR = (
    "pending", "assigned", "done", "wrong_order", "orphaned", "cancelled")
_TAKEN = ("driving", "holding", "serving")


@dataclass(frozen=True)
class TaskLook:
    colour: str       # a colour name above
    label: str        # the text above the disc
    ring: bool        # submitted during the episode
    crossed: bool     # cancelled


@dataclass(frozen=True)
class LeftRobotLook:
    index: int        # the robot's index (its marker id)
    x: float
    y: float
    label: str


def task_look(task: TaskStatus) -> TaskLook:
    if task.status == CANCELLED:
        colour = CANCELLED_COLOUR
    elif task.status == FINISHED:
        colour = DONE
    elif task.orphaned:
        colour = ORPHANED
    elif task.status in _TAKEN:
        colour = ASSIGNED
    else:
        colour = PENDING
    notes = [note for note, shown in (("new", task.submitted), ("cancelled", task.status == CANCELLED),
                                      ("orphaned", task.orphaned)) if shown]
    label = task.id + (f" ({', '.join(notes)})" if notes else "")
    return TaskLook(colour, label, task.submitted, task.status == CANCELLED)


def left_robot_looks(snapshot: FleetSnapshot) -> List[LeftRobotLook]:
    """A cross where each robot that left stands, labelled with its id and why it left."""
    return [LeftRobotLook(i, r.x, r.y, f"{r.id} left" + (f": {r.left_reason}" if r.left_reason else ""))
            for i, r in enumerate(snapshot.robots) if r.status == "left"]


def precedence_edges(snapshot: FleetSnapshot) -> List[Tuple[Tuple[float, float], Tuple[float, float]]]:
    """(from, to) goal positions of every precedence edge between tasks that are not cancelled (a
    cancelled task's successors wait for its own predecessors: those edges are drawn instead)."""
    shown = {t.id: (t.x, t.y) for t in snapshot.tasks if t.status != CANCELLED}
    return [(shown[p], shown[t.id]) for t in snapshot.tasks if t.id in shown for p in t.predecessors if p in shown]
