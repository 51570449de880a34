"""rviz markers of one arena's tasks: pending / assigned / done, precedence arrows, robot -> goal lines;
in event mode from the fleet's snapshot (ros/fleet_status.py), with what ros/task_looks.py chooses
for a live fleet: submitted, cancelled and orphaned tasks, robots that left."""
from __future__ import annotations

from typing import Dict, List, Optional, Sequence, Tuple

from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from marl_mrta.model.scenario import Scenario
from marl_mrta.ros import task_looks
from marl_mrta.ros.fleet_status import FleetSnapshot

PENDING = ColorRGBA(0.55, 0.55, 0.55, 0.9)
ASSIGNED = ColorRGBA(1.0, 0.6, 0.0, 0.95)
DONE = ColorRGBA(0.1, 0.75, 0.2, 0.95)
WRONG_ORDER = ColorRGBA(0.85, 0.1, 0.1, 0.95)
ARROW = ColorRGBA(0.2, 0.4, 0.9, 0.7)
GOAL_LINE = ColorRGBA(1.0, 0.6, 0.0, 0.8)
ORPHANED = ColorRGBA(0.6, 0.2, 0.85, 0.95)
CANCELLED = ColorRGBA(0.2, 0.2, 0.2, 0.5)
NEW_RING = ColorRGBA(0.0, 0.75, 0.9, 0.8)
LEFT_ROBOT = ColorRGBA(0.85, 0.1, 0.1, 0.95)
COLOURS: Dict[str, ColorRGBA] = {task_looks.PENDING: PENDING, task_looks.ASSIGNED: ASSIGNED, task_looks.DONE: DONE,
                                 task_looks.WRONG_ORDER: WRONG_ORDER, task_looks.ORPHANED: ORPHANED,
                                 task_looks.CANCELLED_COLOUR: CANCELLED}


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


def _cross(m: Marker, x: float, y: float, half: float) -> None:
    m.points = [Point(x - half, y - half, 0.06), Point(x + half, y + half, 0.06),
                Point(x - half, y + half, 0.06), Point(x + half, y - half, 0.06)]


def fleet_markers(snapshot: FleetSnapshot, frame: str, stamp, robot_xy: Sequence[Tuple[float, float]],
                  namespace: str = "tasks") -> MarkerArray:
    """Event mode: every marker of the fleet as the snapshot shows it (tasks submitted during the
    episode included, tasks not released left out), after a DELETEALL, so that the tasks of an
    earlier episode and changed looks leave nothing behind. robot_xy: the robots' live positions."""
    markers: List[Marker] = [Marker(action=Marker.DELETEALL, ns=f"{namespace}/goals")]

    def marker(kind: int, ident: int, ns: str) -> Marker:
        m = Marker(type=kind, id=ident, ns=f"{namespace}/{ns}", action=Marker.ADD)
        m.header.frame_id, m.header.stamp = frame, stamp
        m.pose.orientation.w = 1.0
        return m

    goal_of = {}
    for j, task in enumerate(snapshot.tasks):
        look = task_looks.task_look(task)
        goal_of[task.id] = (task.x, task.y)
        disc = marker(Marker.CYLINDER, j, "goals")
        disc.pose.position.x, disc.pose.position.y, disc.pose.position.z = task.x, task.y, 0.01
        disc.scale.x, disc.scale.y, disc.scale.z = 0.25, 0.25, 0.02
        disc.color = COLOURS[look.colour]
        label = marker(Marker.TEXT_VIEW_FACING, j, "labels")
        label.pose.position.x, label.pose.position.y, label.pose.position.z = task.x, task.y + 0.22, 0.2
        label.scale.z = 0.18
        label.color = ColorRGBA(0.1, 0.1, 0.1, 1.0)
        label.text = look.label
        markers += [disc, label]
        if look.ring:
            ring = marker(Marker.CYLINDER, j, "submitted")
            ring.pose.position.x, ring.pose.position.y, ring.pose.position.z = task.x, task.y, 0.005
            ring.scale.x, ring.scale.y, ring.scale.z = 0.36, 0.36, 0.01
            ring.color = NEW_RING
            markers.append(ring)
        if look.crossed:
            cross = marker(Marker.LINE_LIST, j, "cancelled")
            _cross(cross, task.x, task.y, 0.15)
            cross.scale.x = 0.03
            cross.color = WRONG_ORDER
            markers.append(cross)

    for k, (a, b) in enumerate(task_looks.precedence_edges(snapshot)):
        arrow = marker(Marker.ARROW, k, "precedence")
        arrow.points = [Point(a[0], a[1], 0.05), Point(b[0], b[1], 0.05)]
        arrow.scale.x, arrow.scale.y, arrow.scale.z = 0.03, 0.08, 0.1
        arrow.color = ARROW
        markers.append(arrow)

    for i, robot in enumerate(snapshot.robots):
        if robot.task and robot.status != "left" and robot.task in goal_of:
            line = marker(Marker.LINE_STRIP, i, "robot_goal")
            goal = goal_of[robot.task]
            line.points = [Point(robot_xy[i][0], robot_xy[i][1], 0.05), Point(goal[0], goal[1], 0.05)]
            line.scale.x = 0.03
            line.color = GOAL_LINE
            markers.append(line)

    for look in task_looks.left_robot_looks(snapshot):
        cross = marker(Marker.LINE_LIST, look.index, "left_robots")
        _cross(cross, look.x, look.y, 0.2)
        cross.scale.x = 0.05
        cross.color = LEFT_ROBOT
        label = marker(Marker.TEXT_VIEW_FACING, look.index, "left_robot_labels")
        label.pose.position.x, label.pose.position.y, label.pose.position.z = look.x, look.y - 0.3, 0.2
        label.scale.z = 0.15
        label.color = LEFT_ROBOT
        label.text = look.label
        markers += [cross, label]
    return MarkerArray(markers=markers)
