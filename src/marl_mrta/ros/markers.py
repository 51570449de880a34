"""rviz markers of one arena's tasks: pending / assigned / done, precedence arrows, robot -> goal lines."""
from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from marl_mrta.model.scenario import Scenario

PENDING = ColorRGBA(0.55, 0.55, 0.55, 0.9)
ASSIGNED = ColorRGBA(1.0, 0.6, 0.0, 0.95)
DONE = ColorRGBA(0.1, 0.75, 0.2, 0.95)
WRONG_ORDER = ColorRGBA(0.85, 0.1, 0.1, 0.95)
ARROW = ColorRGBA(0.2, 0.4, 0.9, 0.7)
GOAL_LINE = ColorRGBA(1.0, 0.6, 0.0, 0.8)


def task_markers(scenario: Scenario, frame: str, stamp, finished: Sequence[bool],
                 logic_correct: Sequence[Optional[bool]], assigned: Sequence[Optional[int]],
                 robot_xy: Sequence[Tuple[float, float]], namespace: str = "tasks") -> MarkerArray:
    """All markers for the current state. assigned[i]: task index robot i drives to, or None."""
    markers: List[Marker] = []

    def marker(kind: int, ident: int, ns: str) -> Marker:
        m = Marker(type=kind, id=ident, ns=f"{namespace}/{ns}", action=Marker.ADD)
        m.header.frame_id, m.header.stamp = frame, stamp
        m.pose.orientation.w = 1.0
        return m

    busy = {task for task in assigned if task is not None}
    for j, task in enumerate(scenario.tasks):
        disc = marker(Marker.CYLINDER, j, "goals")
        disc.pose.position.x, disc.pose.position.y, disc.pose.position.z = task.goal.x, task.goal.y, 0.01
        disc.scale.x, disc.scale.y, disc.scale.z = 0.25, 0.25, 0.02
        if finished[j]:
            disc.color = DONE if logic_correct[j] is not False else WRONG_ORDER
        else:
            disc.color = ASSIGNED if j in busy else PENDING
        label = marker(Marker.TEXT_VIEW_FACING, j, "labels")
        label.pose.position.x, label.pose.position.y, label.pose.position.z = task.goal.x, task.goal.y + 0.22, 0.2
        label.scale.z = 0.18
        label.color = ColorRGBA(0.1, 0.1, 0.1, 1.0)
        label.text = task.id
        markers += [disc, label]

    arrow_id = 0
    for j, preds in enumerate(scenario.predecessors):
        for p in preds:
            arrow = marker(Marker.ARROW, arrow_id, "precedence")
            arrow_id += 1
            a, b = scenario.tasks[p].goal, scenario.tasks[j].goal
            arrow.points = [Point(a.x, a.y, 0.05), Point(b.x, b.y, 0.05)]
            arrow.scale.x, arrow.scale.y, arrow.scale.z = 0.03, 0.08, 0.1
            arrow.color = ARROW
            markers.append(arrow)

    for i, task in enumerate(assigned):
        line = marker(Marker.LINE_STRIP, i, "robot_goal")
        if task is None:
            line.action = Marker.DELETE
        else:
            goal = scenario.tasks[task].goal
            line.points = [Point(robot_xy[i][0], robot_xy[i][1], 0.05), Point(goal.x, goal.y, 0.05)]
            line.scale.x = 0.03
            line.color = GOAL_LINE
        markers.append(line)
    return MarkerArray(markers=markers)
