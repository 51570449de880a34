"""The ROS-free parts of a live fleet on the task manager: the schedule's status (ros/fleet_status.py),
what rviz shows of it (ros/task_looks.py), the request queue (ros/fleet_requests.py), the robots an
executor no longer drives (ros/event_legs.py's OutOfFleet), per-robot safety faults (ros/safety.py),
a table extended by submitted tasks (model/goal_timeout.py), the `fleet` command's arguments
(apps/fleet_cli.py) and the manager's live-fleet parameters (ros/manager_settings.py)."""
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.apps import fleet_cli
from marl_mrta.common.config import ConfigError
from marl_mrta.env.factory import make_env
from marl_mrta.env.live_fleet import TaskRequest
from marl_mrta.model.goal_timeout import GoalTimeout, LegTimeouts
from marl_mrta.ros import task_looks
from marl_mrta.ros.event_legs import OutOfFleet
from marl_mrta.ros.fleet_requests import FleetRequest, RequestQueue, apply_requests, merged_output
from marl_mrta.ros.fleet_status import (CANCELLED, FINISHED, NOT_YET, OPEN, READY, FleetMarks, FleetSnapshot,
                                        RobotStatus, TaskStatus, describe, fleet_snapshot, same_schedule)
from marl_mrta.ros.manager_settings import read_manager_settings
from marl_mrta.ros.safety import SafetyLimits, SafetyMonitor

ROOT = Path(__file__).resolve().parents[2]
LIVE = ROOT / "test" / "data" / "scenarios" / "live_lab_4r.xml"
LAB_2R = ROOT / "scenarios" / "lab_2r.xml"
NODE = "/rl_task_allocation_manager"


def live_env(scenario):
    return make_env(scenario, decision_mode="event", mask="finished", profile="ideal", seed=0)


def snapshot(env, marks):
    marks.follow(env.rules)
    return fleet_snapshot(env, env.executor.poses(), True, marks)


def by_id(snap):
    return {t.id: t for t in snap.tasks}


# ---------------------------------------------------------------------------- the status

def test_the_status_lists_known_tasks_with_their_robots_and_times():
    """live_lab_4r: A3 and B4 are released later: not listed at the start. Robots sent to A1 and A2
    show driving with them; once A1 is served it is finished by its robot, with its times, and B1
    (after A1) is ready while B2 (after A2) is open."""
    env = live_env(LIVE)
    marks = FleetMarks()
    output = env.reset()
    snap = snapshot(env, marks)
    assert [t.id for t in snap.tasks] == ["A1", "A2", "A4", "B1", "B2", "B3"]
    assert all(t.status in (OPEN, READY) and t.robot == "" and t.released_at == 0.0 for t in snap.tasks)
    assert [r.status for r in snap.robots] == ["idle"] * 4
    a1, a2, n = env.scenario.task_index("A1"), env.scenario.task_index("A2"), env.n_tasks
    output = env.step([a1, a2, n, n])
    while not env.rules.finished[a1]:   # A3's release at 5 s makes the idle robots decide: they stay idle
        output = env.step([n] * env.n_agents)
    snap = snapshot(env, marks)
    tasks = by_id(snap)
    assert tasks["A1"].status == FINISHED and tasks["A1"].robot == "tb3_0"
    assert tasks["A1"].finish == pytest.approx(env.rules.finish_time[a1]) and tasks["A1"].start <= tasks["A1"].finish
    assert tasks["A2"].status == "driving" and tasks["A2"].robot == "tb3_1" and tasks["A2"].start == NOT_YET
    assert tasks["B1"].status == READY and tasks["B2"].status == OPEN and tasks["B2"].predecessors == ("A2",)
    assert snap.robot("tb3_1").status == "driving" and snap.robot("tb3_1").task == "A2"
    assert snap.elapsed == pytest.approx(output.info.elapsed)


def test_submitted_cancelled_and_orphaned_tasks_and_a_robot_that_left():
    """X1 submitted after B1 is marked so; A4 cancelled shows cancelled, never started; tb3_1 leaving
    while it drives to A2 orphans A2 until a robot takes it again."""
    env = live_env(LIVE)
    marks = FleetMarks()
    env.reset()
    ids = env.scenario.task_index
    n = env.n_tasks
    env.step([ids("A1"), ids("A2"), n, n])
    env.submit([TaskRequest("X1", "A", 1.2, 2.5, 0.0, 0.0, ("B1",))])
    env.cancel("A4")
    snap = snapshot(env, marks)
    tasks = by_id(snap)
    assert tasks["X1"].submitted and not tasks["A1"].submitted and tasks["X1"].predecessors == ("B1",)
    assert tasks["X1"].released_at == pytest.approx(env.elapsed)
    assert tasks["A4"].status == CANCELLED and tasks["A4"].start == NOT_YET
    env.leave("tb3_1", "battery")
    snap = snapshot(env, marks)
    assert snap.task("A2").orphaned and snap.task("A2").status in (OPEN, READY)
    assert snap.robot("tb3_1").status == "left" and snap.robot("tb3_1").left_reason.startswith("battery")
    # Taken again: no longer orphaned.
    output = env.current_output()
    deciding = [i for i, d in enumerate(output.deciding) if d]
    actions = [n] * env.n_agents
    actions[deciding[0]] = ids("A2")
    env.step(actions)
    assert not snapshot(env, marks).task("A2").orphaned
    assert "A2" in "\n".join(describe(snap)) and "(orphaned)" in "\n".join(describe(snap))


def test_a_new_snapshot_is_published_only_when_the_schedule_changes():
    robots = (RobotStatus("tb3_0", "driving", "A1", 0.0, 0.0),)
    task = TaskStatus("A1", "A", "driving", "tb3_0", (), False, False, 0.0, NOT_YET, NOT_YET, 1.0, 1.0)
    a = FleetSnapshot(True, 1.0, (task,), robots)
    moved = FleetSnapshot(True, 2.0, (task,), (RobotStatus("tb3_0", "driving", "A1", 0.5, 0.0),))
    assert same_schedule(a, moved)
    finished = FleetSnapshot(True, 3.0, (TaskStatus("A1", "A", FINISHED, "tb3_0", (), False, False, 0.0, 2.0, 3.0,
                                                    1.0, 1.0),), robots)
    assert not same_schedule(a, finished) and not same_schedule(None, a)


# ---------------------------------------------------------------------------- what rviz shows

def _task(status, submitted=False, orphaned=False, preds=(), x=1.0, task_id="T"):
    return TaskStatus(task_id, "A", status, "", tuple(preds), submitted, orphaned, 0.0, NOT_YET, NOT_YET, x, 1.0)


@pytest.mark.parametrize("task, colour, label, ring, crossed", [
    (_task(OPEN), task_looks.PENDING, "T", False, False),
    (_task(READY), task_looks.PENDING, "T", False, False),
    (_task("driving"), task_looks.ASSIGNED, "T", False, False),
    (_task("serving"), task_looks.ASSIGNED, "T", False, False),
    (_task(FINISHED), task_looks.DONE, "T", False, False),
    (_task(OPEN, submitted=True), task_looks.PENDING, "T (new)", True, False),
    (_task(CANCELLED), task_looks.CANCELLED_COLOUR, "T (cancelled)", False, True),
    (_task(CANCELLED, submitted=True), task_looks.CANCELLED_COLOUR, "T (new, cancelled)", True, True),
    (_task(READY, orphaned=True), task_looks.ORPHANED, "T (orphaned)", False, False),
])
def test_each_task_looks_as_its_status_says(task, colour, label, ring, crossed):
    assert task_looks.task_look(task) == task_looks.TaskLook(colour, label, ring, crossed)


def test_robots_that_left_are_crossed_and_arrows_skip_cancelled_tasks():
    tasks = (_task(FINISHED, task_id="A", x=0.0), _task(CANCELLED, preds=("A",), task_id="B", x=1.0),
             _task(OPEN, preds=("A",), task_id="C", x=2.0))
    robots = (RobotStatus("tb3_0", "idle", "", 0.0, 0.0), RobotStatus("tb3_1", "left", "", 3.0, 4.0, "battery"))
    snap = FleetSnapshot(True, 5.0, tasks, robots)
    assert task_looks.left_robot_looks(snap) == [task_looks.LeftRobotLook(1, 3.0, 4.0, "tb3_1 left: battery")]
    assert task_looks.precedence_edges(snap) == [((0.0, 1.0), (2.0, 1.0))]


def test_the_markers_draw_what_the_looks_say():
    pytest.importorskip("visualization_msgs.msg", reason="ROS message packages are needed")
    from visualization_msgs.msg import Marker
    from marl_mrta.ros import markers
    tasks = (_task(FINISHED, task_id="A", x=0.0), _task(CANCELLED, submitted=True, preds=("A",), task_id="B", x=1.0),
             _task("driving", preds=("A",), task_id="C", x=2.0))
    robots = (RobotStatus("tb3_0", "driving", "C", 0.0, 0.0), RobotStatus("tb3_1", "left", "", 3.0, 4.0, "battery"))
    array = markers.fleet_markers(FleetSnapshot(True, 5.0, tasks, robots), "map", 0, [(0.5, 0.5), (3.0, 4.0)])
    assert array.markers[0].action == Marker.DELETEALL
    drawn = array.markers[1:]
    count = {}
    for m in drawn:
        count[m.ns] = count.get(m.ns, 0) + 1
    assert count == {"tasks/goals": 3, "tasks/labels": 3, "tasks/submitted": 1, "tasks/cancelled": 1,
                     "tasks/precedence": 1, "tasks/robot_goal": 1, "tasks/left_robots": 1, "tasks/left_robot_labels": 1}
    assert len({(m.ns, m.id) for m in drawn}) == len(drawn)
    discs = {m.id: m for m in drawn if m.ns == "tasks/goals"}
    assert discs[1].color == markers.CANCELLED and discs[2].color == markers.ASSIGNED
    line = next(m for m in drawn if m.ns == "tasks/robot_goal")
    assert (line.points[1].x, line.points[1].y) == (2.0, 1.0)


# ---------------------------------------------------------------------------- requests

class _Env:
    def __init__(self):
        self.elapsed = 4.0
        self.refused = []

    def refuse(self, what, reason):
        self.refused.append((what, reason))


def test_requests_wait_in_order_and_a_withdrawn_one_is_never_applied():
    from marl_mrta.env.live_fleet import FleetRequestError
    queue = RequestQueue()
    applied = []
    ok = FleetRequest("cancel A", lambda env: applied.append("A") or "out-A", "cancelled A")

    def bad(env):
        raise FleetRequestError("cancel B: no such task")
    refused = FleetRequest("cancel B", bad, "cancelled B")
    late = FleetRequest("cancel C", lambda env: applied.append("C"), "cancelled C")
    for request in (ok, refused, late):
        queue.put(request)
    assert queue.waiting()
    assert queue.withdraw(late) and not queue.withdraw(late)
    env = _Env()
    output = apply_requests(env, queue.take(), running=True)
    assert output == "out-A" and applied == ["A"] and not queue.waiting()
    assert (ok.ok, ok.message, ok.applied_at) == (True, "cancelled A at 4.00 s", 4.0)
    assert (refused.ok, refused.message) == (False, "cancel B: no such task")
    assert ok.answered.is_set() and refused.answered.is_set() and not late.answered.is_set()
    assert env.refused == [("cancel B", "cancel B: no such task")]
    # With no episode running the refusal is answered, and no record is touched.
    again = FleetRequest("cancel B", bad, "cancelled B")
    apply_requests(env, [again], running=False)
    assert not again.ok and len(env.refused) == 1


def test_a_transition_ended_by_requests_keeps_its_rewards_and_shows_the_fleet_after_them():
    env = live_env(LAB_2R)
    env.reset()
    n = env.n_tasks
    transition = env.step([env.scenario.task_index("A1"), env.scenario.task_index("A3")])
    after = env.cancel("B4")
    merged = merged_output(transition, after)
    assert np.array_equal(merged.rewards, transition.rewards)
    assert np.array_equal(merged.action_mask, after.action_mask) and np.array_equal(merged.deciding, after.deciding)
    assert merged.info.step_duration == transition.info.step_duration
    assert merged.info.robot_tasks == after.info.robot_tasks
    assert not merged.action_mask[:, env.scenario.task_index("B4")].any() and merged.action_mask[:, n].all()


# ---------------------------------------------------------------------------- executors' bookkeeping

def test_out_of_fleet_reports_its_own_losses_once_and_keeps_them_for_the_episode():
    out = OutOfFleet()
    assert out.lose(1, "tb3_1: odom silent for 1.1 s") and not out.lose(1, "again")
    assert out.let_go(0) and not out.let_go(0)
    assert 0 in out and 1 in out and out.unreported()
    assert out.take() == [(1, "tb3_1: odom silent for 1.1 s")] and out.take() == [] and not out.unreported()
    assert out.losses() == [(1, "tb3_1: odom silent for 1.1 s")]
    out.back(0)
    assert 0 not in out
    out.clear()
    assert 1 not in out and out.losses() == []


def test_a_robots_own_fault_is_told_apart_from_the_fleets_and_an_excused_robot_is_not_watched():
    monitor = SafetyMonitor(["tb3_0", "tb3_1"], SafetyLimits(odom_silent_after=1.0, scan_silent_after=1.0,
                                                             move_base_silent_after=2.0, master_lost_after=1.0))
    for robot in (0, 1):
        for part in ("odom", "scan", "move_base"):
            monitor.heard(robot, part, 10.0)
    monitor.master_answered(10.0)
    for part in ("odom", "scan", "move_base"):
        monitor.heard(0, part, 11.5)
    monitor.master_answered(11.5)
    assert monitor.robot_faults(11.5) == [(1, "tb3_1: odom silent for 1.5 s")]
    assert monitor.fleet_fault(11.5) == "" and monitor.fault(11.5) == "tb3_1: odom silent for 1.5 s"
    monitor.excuse(1)
    assert monitor.robot_faults(11.5) == [] and monitor.fault(11.5) == ""
    assert monitor.fleet_fault(13.0).startswith("ROS master unreachable for 1.5 s")
    monitor.watch_again(1)
    assert monitor.robot_faults(11.5)[0][0] == 1
    monitor.excuse(1)
    monitor.rearm(11.5)   # a new episode: every robot watched again
    assert monitor.robot_faults(11.5)[0][0] == 1


def test_submitted_tasks_extend_the_leg_timeouts():
    nominal = [[0.0, 10.0], [10.0, 0.0]]   # one robot's start, one task
    timeouts = LegTimeouts(GoalTimeout(None, 2.0, 30.0), 1, nominal)
    timeouts.extend([[0.0, 10.0, 20.0], [10.0, 0.0, 5.0], [20.0, 5.0, 0.0]])
    assert timeouts.limit(0, 1) == 2 * 20.0 + 30.0
    timeouts.reached(0, 0)
    assert timeouts.limit(0, 1) == 2 * 5.0 + 30.0
    fixed = LegTimeouts(GoalTimeout(60.0), 1)
    fixed.extend(nominal)
    assert fixed.limit(0, 5) == 60.0


# ---------------------------------------------------------------------------- the fleet command

def test_the_fleet_command_reads_each_request():
    args = fleet_cli.parse_args(["submit", "X1", "A", "1.2", "2.5", "--yaw", "1.57", "--service-time", "2",
                                 "--after", "A1", "B1"])
    assert args.tasks == [fleet_cli.TaskLine("X1", "A", 1.2, 2.5, 1.57, 2.0, ("A1", "B1"))]
    assert fleet_cli.parse_args(["--manager", "/m", "cancel", "B4"]).id == "B4"
    leave = fleet_cli.parse_args(["leave", "tb3_1", "--reason", "battery low"])
    assert (leave.robot, leave.reason, leave.manager) == ("tb3_1", "battery low", "/rl_task_allocation_manager")
    assert fleet_cli.parse_args(["join", "tb3_1"]).robot == "tb3_1"
    assert fleet_cli.parse_args(["--timeout", "3", "status"]).timeout == 3.0


def test_a_task_file_gives_several_tasks(tmp_path):
    path = tmp_path / "tasks.yaml"
    path.write_text("- {id: X1, category: A, x: 1.2, y: 2.5, after: [B1]}\n"
                    "- {id: X2, category: B, x: 4, y: 1, yaw: 3.14, service_time: 2, after: X1}\n")
    args = fleet_cli.parse_args(["submit", "--file", str(path)])
    assert args.tasks == [fleet_cli.TaskLine("X1", "A", 1.2, 2.5, 0.0, 0.0, ("B1",)),
                          fleet_cli.TaskLine("X2", "B", 4.0, 1.0, 3.14, 2.0, ("X1",))]


@pytest.mark.parametrize("argv, problem", [
    ([], "give a command: submit, cancel, leave, join or status"),
    (["fly"], "invalid choice: 'fly'"),
    (["submit", "X1", "A", "1.2"], "submit: expected ID CATEGORY X Y, got 3 value(s)"),
    (["submit", "X1", "A", "one", "2"], "submit: X: expected a number, got 'one'"),
    (["cancel"], "the following arguments are required: id"),
    (["--timeout", "0", "status"], "--timeout: must be a positive number of seconds, got 0"),
    (["submit", "X1", "A", "1", "2", "--file", "t.yaml"], "submit: give either one task on the command line or --file"),
])
def test_a_bad_command_line_is_one_line_and_exit_status_2(argv, problem, capsys):
    with pytest.raises(fleet_cli.UsageError) as error:
        fleet_cli.parse_args(argv)
    assert problem in str(error.value) and "\n" not in str(error.value)
    assert fleet_cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("fleet: ") and "Traceback" not in err


@pytest.mark.parametrize("text, problem", [
    ("- {id: X1, category: A, x: 1}\n", "task 1: missing 'y'"),
    ("- {id: X1, category: A, x: 1, y: 2, colour: red}\n", "task 1: unknown key 'colour'"),
    ("- {id: X1, category: A, x: 1, y: [2]}\n", "task 1: 'y': expected a number"),
    ("- {id: X1, category: A, x: 1, y: 2, after: {A1: 1}}\n", "task 1: 'after': expected a list of task ids"),
    ("id: X1\n", "expected a list of tasks"),
    ("- [unclosed\n", "not YAML"),
])
def test_a_bad_task_file_names_the_task_and_the_key(tmp_path, text, problem):
    path = tmp_path / "tasks.yaml"
    path.write_text(text)
    with pytest.raises(fleet_cli.UsageError) as error:
        fleet_cli.read_task_file(path)
    assert problem in str(error.value) and str(error.value).startswith(str(path)) and "\n" not in str(error.value)


# ---------------------------------------------------------------------------- the manager's parameters

def test_the_live_fleet_parameters_and_their_defaults():
    settings = read_manager_settings({"scenario": "s.xml"}, NODE)
    assert settings.live.allocator == "client" and settings.executor.on_robot_fault == "stop_fleet"
    assert settings.decision_mode is None and settings.live.episodes == 1 and not settings.live.end_when_done
    replan = read_manager_settings({"scenario": "s.xml", "allocator": "replan", "on_robot_fault": "continue",
                                    "episodes": 3, "out": "/tmp/r.json", "end_when_done": True}, NODE)
    assert replan.decision_mode == "event"   # the replanning allocator decides on events
    assert (replan.live.episodes, replan.live.out, replan.live.end_when_done) == (3, "/tmp/r.json", True)
    assert replan.executor.on_robot_fault == "continue"


@pytest.mark.parametrize("params, message", [
    ({"allocator": "planner"}, NODE + "/allocator: 'planner' is not one of client, replan"),
    ({"on_robot_fault": "ignore"}, NODE + "/on_robot_fault: 'ignore' is not one of stop_fleet, continue"),
    ({"allocator": "replan", "decision_mode": "synchronous"},
     NODE + "/decision_mode: synchronous: allocator replan decides in event mode"),
    ({"episodes": 0}, NODE + "/episodes: must be >= 1, got 0"),
    ({"request_wait": 0}, NODE + "/request_wait: must be > 0.0, got 0.0"),
])
def test_a_bad_live_fleet_parameter_is_one_line(params, message):
    with pytest.raises(ConfigError) as error:
        read_manager_settings({"scenario": "s.xml", **params}, NODE)
    assert message in str(error.value) and "\n" not in str(error.value)
