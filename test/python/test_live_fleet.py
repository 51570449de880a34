"""A live fleet (env/live_fleet.py, model/event_rules.py, baselines/replan.py): tasks released over
time, submitted and cancelled while the robots work, robots that leave or join; every released
task is done in order or reported, a cancelled task is never started, a robot's task returns to
the pool when it leaves, a bad request changes nothing, and the live fleet is never shorter than
the same planner told everything at the start."""
import dataclasses
import math
import random
from pathlib import Path

import pytest

from marl_mrta.baselines.plan import SchedulingInstance, decode_routes
from marl_mrta.baselines.replan import full_information_instance, repair
from marl_mrta.baselines.settings import ReplanSettings, load_baseline_settings
from marl_mrta.env.factory import make_env
from marl_mrta.env.live_fleet import FleetRequestError, TaskRequest
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.policies import ReplanPolicy
from marl_mrta.model.event_rules import DRIVING, HOLDING, IDLE, LEFT, SERVING, EventOutcome, EventRules
from marl_mrta.model.live_variants import live_variant, release_order, write_variant
from marl_mrta.model.scenario import ScenarioError, load_scenario

ROOT = Path(__file__).resolve().parents[2]
LIVE = ROOT / "test" / "data" / "scenarios" / "live_lab_4r.xml"
LAB = ROOT / "scenarios" / "lab_4r.xml"
SITE = ROOT / "scenarios" / "site_8r.xml"
QUICK = ReplanSettings(method="ga", ga_evaluations=400)


def live_env(scenario):
    return make_env(scenario, decision_mode="event", mask="finished", profile="ideal", seed=0)


def served_before_its_successors(record, predecessors):
    """Every finished task started its service no earlier than each predecessor's finish."""
    start = {e.task: e.service_start for e in record.entries if e.finished}
    return all(start[j] >= record.finish_time[p] - 1e-9 for j in start for p in predecessors[j])


# ---------------------------------------------------------------------------- the scenario file

def test_releases_and_faults_are_read():
    scenario = load_scenario(LIVE)
    assert scenario.live
    assert {t.id: t.release for t in scenario.tasks if t.release} == {"A3": 5.0, "B4": 12.0}
    assert [(scenario.robots[f.robot].id, f.at) for f in scenario.faults] == [("tb3_1", 8.0)]
    assert not load_scenario(LAB).live


@pytest.mark.parametrize("edit, problem", [
    (('release="5"', 'release="-1"'), "release must not be negative"),
    (('<fault robot="tb3_1" at="8"/>', '<fault robot="tb3_9" at="8"/>'), "unknown robot 'tb3_9'"),
    (('<fault robot="tb3_1" at="8"/>', '<fault robot="tb3_1" at="8"/><fault robot="tb3_1" at="9"/>'),
     "given a fault more than once"),
    (('<fault robot="tb3_1" at="8"/>', '<fault robot="tb3_1"/>'), "missing attribute 'at'"),
    (('<episode timeout="240"/>', '<episode timeout="10"/>'), "cannot be finished in order"),
])
def test_bad_releases_and_faults_give_one_line(tmp_path, edit, problem):
    text = LIVE.read_text().replace(*edit).replace("../../../maps/lab.yaml", str(ROOT / "maps" / "lab.yaml"))
    path = tmp_path / "bad.xml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    assert problem in str(error.value) and "\n" not in str(error.value)
    assert str(error.value).startswith(str(path))


# ---------------------------------------------------------------------------- the rules

def rules_of(preds, n_robots=2, known=None):
    return EventRules(n_robots, preds, [0.0] * len(preds), 1.0, known)


def test_an_unknown_task_is_no_ones_until_its_release_makes_the_idle_decide():
    rules = rules_of([(), ()], known=[True, False])
    rules.assign(0, 0, 0.0)
    rules.assign(1, None, 0.0)
    assert not rules.ready(1) and not rules.open(1) and not rules.done
    outcome = EventOutcome(3.0)
    rules.release(1, 3.0, outcome)
    assert rules.ready(1) and 1 in rules.due


def test_a_cancelled_task_frees_its_robot_and_its_successors_wait_for_its_predecessors():
    rules = rules_of([(), (0,), (1,)])   # 0 -> 1 -> 2
    rules.assign(0, 1, 0.0)               # driving to 1
    rules.assign(1, None, 0.0)
    outcome = EventOutcome(1.0)
    freed = rules.cancel(1, 1.0, outcome)
    assert freed == [0] and rules.robots[0].phase == IDLE and 0 in rules.due
    assert rules.predecessors[2] == (0,)   # bridged: 2 still waits for 0
    assert not rules.ready(2)
    with pytest.raises(ValueError, match="already cancelled"):
        rules.cancel(1, 2.0, outcome)


def test_a_task_in_service_is_not_cancelled():
    rules = EventRules(1, [()], [5.0], 1.0)
    rules.assign(0, 0, 0.0)
    rules.leg_ended(0, 2.0, True)
    assert rules.robots[0].phase == SERVING
    with pytest.raises(ValueError, match="in service"):
        rules.cancel(0, 3.0, EventOutcome(3.0))


def test_a_robot_that_leaves_returns_its_task_to_the_pool():
    rules = rules_of([(), (0,)])
    rules.assign(0, 1, 0.0)
    rules.assign(1, 0, 0.0)
    rules.leg_ended(0, 2.0, True)          # robot 0 holds at 1 (0 not finished)
    assert rules.robots[0].phase == HOLDING
    outcome = EventOutcome(3.0)
    driving = rules.remove_robot(0, 3.0, "fault", outcome)
    assert not driving and rules.robots[0].phase == LEFT and not rules.present(0)
    assert outcome.ended and outcome.ended[0].task == 1 and outcome.ended[0].failure == "fault"
    assert not rules.taken(1) and not rules.finished[1]
    assert rules.robots[1].phase == DRIVING     # the other robot goes on
    with pytest.raises(ValueError):
        rules.remove_robot(0, 4.0, "again", outcome)
    rules.add_robot(0, 5.0)
    assert rules.robots[0].phase == IDLE and 0 in rules.due


# ---------------------------------------------------------------------------- episodes

def test_a_live_scenario_is_done_in_order_with_nothing_started_before_its_release():
    scenario = load_scenario(LIVE)
    env = live_env(scenario)
    record = run_episode(env, ReplanPolicy(env, QUICK), seed=0)
    assert record.complete and record.logic_consistent
    assert served_before_its_successors(record, scenario.predecessors)
    release = {j: t.release for j, t in enumerate(scenario.tasks)}
    assert all(e.start >= release[e.task] - 1e-9 for e in record.entries)   # not even driven to before
    lost = [e for e in record.fleet_events if e["event"] == "left"]
    assert [e["subject"] for e in lost] == ["tb3_1"] and lost[0]["time"] == pytest.approx(8.0)
    assert all(e.robot != 1 or e.start < 8.0 for e in record.entries)        # it decides nothing after
    assert record.released_at[scenario.task_index("B4")] == pytest.approx(12.0)


def test_unknown_tasks_are_masked_for_every_policy():
    scenario = load_scenario(LIVE)
    env = make_env(scenario, decision_mode="event", mask="none", profile="ideal", seed=0)
    output = env.reset(seed=0)
    unknown = [j for j, t in enumerate(scenario.tasks) if t.release > 0]
    assert not output.action_mask[:, unknown].any()
    assert output.action_mask[:, [j for j in range(env.n_tasks) if j not in unknown]].any()


def test_the_live_fleet_is_never_shorter_than_the_planner_told_everything():
    """A relation: the live fleet's episode is one schedule of the full-information instance
    (nominal legs, releases kept, the lost robot's tasks done before it left), so its makespan is
    at least that instance's optimum, of which CP-SAT's bound is a lower bound."""
    scenario = load_scenario(SITE)
    settings = load_baseline_settings().replan
    for seed in (1, 2):
        variant = live_variant(scenario, seed, 0.25, 25.0, faults=1, fault_window=(10.0, 30.0))
        env = live_env(variant)
        record = run_episode(env, ReplanPolicy(env, dataclasses.replace(settings, time_limit=1.0)), seed=0)
        assert record.complete and record.logic_consistent
        full = full_information_instance(variant, env.table, env.settings.goal_timeout.planning_limit, 1.0)
        # What the live fleet did is a plan of the full instance (one that may also drive towards a
        # task before its release): as a first plan, the planner told everything ends no later.
        live_routes = record.robot_task_lists()
        assert decode_routes(full, live_routes).elapsed <= record.makespan + 1e-6
        plan = repair(full, live_routes, dataclasses.replace(settings, time_limit=5.0))
        assert plan.usable and plan.makespan <= record.makespan + 1e-6
        assert plan.details["lower_bound"] <= plan.makespan + 1e-6


# ---------------------------------------------------------------------------- requests

def started_episode(scenario=LAB, steps=2):
    scenario = load_scenario(scenario)
    env = live_env(scenario)
    policy = ReplanPolicy(env, QUICK)
    output = env.reset(seed=0)
    policy.begin_episode(output)
    for _ in range(steps):
        output = env.step(policy.act(output))
    return env, policy, output


def finish(env, policy, output):
    while not (output.done or output.truncated):
        output = env.step(policy.act(output))
    return output.info.episode


def test_a_submitted_task_is_done_after_its_predecessor():
    env, policy, _ = started_episode()
    output = env.submit([TaskRequest("C1", "C", 3.5, 2.5, 0.0, 1.0, ("B1",))])
    assert env.n_tasks == 9 and output.action_mask.shape == (4, 10)
    record = finish(env, policy, output)
    c1, b1 = env.scenario.task_index("C1"), env.scenario.task_index("B1")
    assert record.complete and record.logic_consistent
    assert record.finish_time[c1] - 1.0 >= record.finish_time[b1] - 1e-9
    assert record.task_ids[-1] == "C1" and record.released_at[c1] > 0.0
    # the next episode is the scenario's own again
    assert env.reset(seed=0).action_mask.shape == (4, 9)


@pytest.mark.parametrize("request_, problem", [
    (TaskRequest("C1", "C", 3.5, 2.5, 0.0, 0.0, ("Z9",)), "unknown predecessor 'Z9'"),
    (TaskRequest("A1", "C", 3.5, 2.5, 0.0), "duplicate id"),
    (TaskRequest("C1", "C", 1.75, 1.5, 0.0), "inside an obstacle"),
    (TaskRequest("C1", "C", -50.0, 2.5, 0.0), "off the map"),
    (TaskRequest("C1", "C", 3.5, 2.5, 0.0, -1.0), "service_time must not be negative"),
    (TaskRequest("C1", "C", 4.45, 4.2, 0.0), "closer than a robot's footprint to the goal of task B3"),
    # a free cell next to a wall: navigation cannot plan to it, so no robot can reach it
    (TaskRequest("C1", "C", 2.0, 1.35, 0.0), "inscribed zone of the global costmap"),
])
def test_a_bad_submission_gives_one_line_and_changes_nothing(request_, problem):
    env, policy, output = started_episode()
    before = (env.n_tasks, env.rules.snapshot(), list(env.record.task_ids), len(env.record.entries))
    with pytest.raises(FleetRequestError) as error:
        env.submit([request_])
    assert problem in str(error.value) and "\n" not in str(error.value)
    assert (env.n_tasks, env.rules.snapshot(), list(env.record.task_ids), len(env.record.entries)) == before
    record = finish(env, policy, output)
    assert record.complete and record.logic_consistent


def test_a_cycle_among_submitted_tasks_is_refused():
    env, _, _ = started_episode()
    with pytest.raises(FleetRequestError, match="cycle: "):
        env.submit([TaskRequest("C1", "C", 3.5, 2.5, 0.0, 0.0, ("C2",)),
                    TaskRequest("C2", "C", 3.5, 3.5, 0.0, 0.0, ("C1",))])
    assert env.n_tasks == 8


def test_a_cancelled_task_is_never_started():
    env, policy, output = started_episode(steps=1)
    robot = next(r for r, state in enumerate(env.rules.robots) if state.phase == DRIVING)
    target = env.rules.robots[robot].task           # a robot drives there now
    task_id = env.scenario.tasks[target].id
    output = env.cancel(task_id)
    assert env.rules.robots[robot].phase == IDLE and output.deciding[robot]
    record = finish(env, policy, output)
    assert record.complete and record.logic_consistent
    assert record.finish_time[target] is None
    assert all(e.service_start is None for e in record.entries if e.task == target)
    assert task_id in record.cancelled_tasks()
    with pytest.raises(FleetRequestError, match="no episode"):
        env.cancel("A2")


def test_a_robot_that_leaves_has_its_task_done_by_another():
    env, policy, output = started_episode(steps=1)
    robot = next(r for r, state in enumerate(env.rules.robots) if state.phase == DRIVING)
    task = env.rules.robots[robot].task
    output = env.leave(env.scenario.robots[robot].id, "battery")
    assert not env.rules.present(robot)
    with pytest.raises(FleetRequestError, match="has left already"):
        env.leave(env.scenario.robots[robot].id)
    record = finish(env, policy, output)
    assert record.complete and record.logic_consistent
    assert record.finished_by[task] is not None and record.finished_by[task] != robot


def test_a_robot_that_joins_again_takes_work():
    env, policy, output = started_episode(steps=0)
    output = env.leave("tb3_0")
    output = env.join("tb3_0")
    assert env.rules.present(0) and output.deciding[0]
    with pytest.raises(FleetRequestError, match="in the fleet already"):
        env.join("tb3_0")
    with pytest.raises(FleetRequestError, match="no such robot"):
        env.join("tb3_9")
    record = finish(env, policy, output)
    assert record.complete and any(e.robot == 0 and e.finished for e in record.entries)


def test_every_robot_gone_ends_the_episode_with_the_reason():
    env, policy, output = started_episode(steps=0)
    for robot in env.scenario.robots:
        output = env.leave(robot.id)
    record = finish(env, policy, output)
    assert not record.complete and record.abort_reason == "every robot has left the fleet"


# ---------------------------------------------------------------------------- planning

def test_a_plan_keeps_commitments_ready_times_and_deadlines():
    travel = [[0, 9, 5, 5], [9, 0, 5, 5], [5, 5, 0, 1], [5, 5, 1, 0]]   # 2 robots, 2 tasks
    instance = SchedulingInstance(2, 2, travel, (1.0, 1.0), ((), ()), decision_mode="event",
                                  robot_ready=(10.0, 0.0), first_task=(1, None), task_release=(0.0, 0.0),
                                  robot_deadline=(math.inf, 6.5))
    run = decode_routes(instance, [[0], [1]])           # robot 0 committed to task 1: it goes first
    assert run.robot_tasks[0][0] == 1 or 1 in run.robot_tasks[0]
    assert run.arrival[1] == pytest.approx(15.0)        # from its ready time
    plan = repair(instance, [], ReplanSettings(method="cpsat", time_limit=1.0))
    assert plan.robot_tasks[0][0] == 1
    # robot 1 must be done by 6.5: task 0 (reached at 5, served to 6) fits, both do not
    assert plan.usable and plan.robot_tasks[1] in ([0], [])


def test_release_order_keeps_precedence_and_a_variant_file_reads_back(tmp_path):
    scenario = load_scenario(SITE)
    rng = random.Random(3)
    order = release_order(scenario.predecessors, rng)
    position = {t: k for k, t in enumerate(order)}
    assert all(position[p] < position[j] for j in range(scenario.n_tasks) for p in scenario.predecessors[j])
    variant = live_variant(scenario, 4, 0.25, 30.0, faults=2, fault_window=(10.0, 20.0), name_suffix="_v")
    released = [t.release for t in variant.tasks]
    assert sum(1 for r in released if r == 0.0) >= round(0.25 * scenario.n_tasks)
    for j in range(scenario.n_tasks):
        assert all(released[p] <= released[j] for p in scenario.predecessors[j])
    again = load_scenario(write_variant(variant, tmp_path / "v.xml"))
    assert [t.release for t in again.tasks] == released
    assert again.faults == variant.faults and again.name == "site_8r_v"
