"""rviz markers of the task manager: tasks pending / assigned / done (wrong order red), one
precedence arrow per edge from predecessor to successor, a robot -> goal line per driving robot."""
from pathlib import Path

import pytest

pytest.importorskip("visualization_msgs.msg", reason="ROS message packages are needed")

from visualization_msgs.msg import Marker  # noqa: E402

from marl_mrta.ros import markers  # noqa: E402
from marl_mrta.model.scenario import load_scenario  # noqa: E402

LAB_2R = Path(__file__).resolve().parents[2] / "scenarios" / "lab_2r.xml"


def rgb(color):
    return (round(color.r, 3), round(color.g, 3), round(color.b, 3))


def by_ns(array, suffix):
    return [m for m in array.markers if m.ns.endswith(suffix)]


def test_colours_arrows_and_lines_follow_the_state():
    scenario = load_scenario(LAB_2R)
    a1, a2, b1, b2 = (scenario.task_index(t) for t in ("A1", "A2", "B1", "B2"))
    finished = [False] * scenario.n_tasks
    correct = [None] * scenario.n_tasks
    finished[a1], correct[a1] = True, True
    finished[b2], correct[b2] = True, False          # B2 before A2: wrong order
    assigned = [a2, None]                            # robot 0 drives to A2, robot 1 waits
    array = markers.task_markers(scenario, "map", 0, finished, correct, assigned, [(0.5, 0.5), (0.5, 4.5)])

    discs = {m.id: m for m in by_ns(array, "/goals")}
    assert len(discs) == scenario.n_tasks
    assert rgb(discs[a1].color) == rgb(markers.DONE)
    assert rgb(discs[b2].color) == rgb(markers.WRONG_ORDER)
    assert rgb(discs[a2].color) == rgb(markers.ASSIGNED)
    assert rgb(discs[b1].color) == rgb(markers.PENDING)
    assert discs[a1].pose.position.x == scenario.tasks[a1].goal.x
    assert all(m.header.frame_id == "map" for m in array.markers)
    labels = sorted(m.text for m in by_ns(array, "/labels"))
    assert labels == sorted(t.id for t in scenario.tasks)

    arrows = by_ns(array, "/precedence")
    edges = {(p, j) for j, preds in enumerate(scenario.predecessors) for p in preds}
    assert len(arrows) == len(edges) == 4
    drawn = {((a.points[0].x, a.points[0].y), (a.points[1].x, a.points[1].y)) for a in arrows}
    expected = {((scenario.tasks[p].goal.x, scenario.tasks[p].goal.y),
                 (scenario.tasks[j].goal.x, scenario.tasks[j].goal.y)) for p, j in edges}
    assert drawn == expected

    lines = sorted(by_ns(array, "/robot_goal"), key=lambda m: m.id)
    assert [m.action for m in lines] == [Marker.ADD, Marker.DELETE]
    assert (lines[0].points[0].x, lines[0].points[0].y) == (0.5, 0.5)
    assert (lines[0].points[1].x, lines[0].points[1].y) == (scenario.tasks[a2].goal.x, scenario.tasks[a2].goal.y)
    assert len({(m.ns, m.id) for m in array.markers}) == len(array.markers)   # no marker overwrites another
