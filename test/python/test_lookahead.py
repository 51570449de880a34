"""The robots' own decisions with lookahead (evaluation/lookahead.py): each robot plays the team's
actor out from the state in its own observation row before it answers. The state it reads is the
environment's; an episode resumed there goes on as the original; the lookahead reaches lab_3r's
optimum that the actor alone misses, is never longer than the actor's own episodes under any
orientation, keeps the rollout plan it opens with until a search beats it, keeps a precedence
margin when given one, and runs through
`evaluate --method lookahead`."""
import json
import math
import re

import pytest

from marl_mrta.apps.evaluate import main as evaluate_main
from marl_mrta.baselines.exact import solve_exact
from marl_mrta.baselines.reference import scheduling_instance
from marl_mrta.baselines.settings import LookaheadBudget, load_baseline_settings
from marl_mrta.common.paths import package_root
from marl_mrta.env.factory import make_env
from marl_mrta.env.settings import load_task_settings
from marl_mrta.evaluation.lookahead import Lookahead
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.robot_actor import in_process_team
from marl_mrta.mappo.policy import load_policy
from marl_mrta.model.scenario import load_scenario

LAB = package_root() / "scenarios"


@pytest.fixture(autouse=True)
def one_thread():
    """Play-outs are many small forward passes; two threads per test process on two shared cores crawl."""
    import torch
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def bound(path, **budget):
    scenario = load_scenario(path)
    policy = load_policy("generalist").for_scenario(scenario)
    settings = load_baseline_settings().lookahead
    return scenario, policy, Lookahead(policy, LookaheadBudget(**{**settings.__dict__, **budget}))


def episode(scenario, team):
    record = run_episode(make_env(scenario, "embedded", profile="ideal", mask="finished"), team, seed=0)
    assert record.complete and record.logic_consistent
    return record


def test_each_robot_reads_the_state_from_its_own_row_and_the_episode_resumes_there():
    scenario, policy, lookahead = bound(LAB / "lab_4r.xml")
    env = make_env(scenario, "embedded", profile="ideal", mask="finished")
    output = env.reset(seed=0)
    hidden = policy.initial_hidden(env.n_agents)
    joints = []
    for _ in range(1):   # a step in (of two): robots on task nodes, tasks finished
        actions, hidden = policy.act_team(output.obs, output.action_mask, hidden)
        joints.append([int(a) for a in actions])
        output = env.step(joints[-1])
    assert any(output.info.finished) and not output.done
    for robot in range(env.n_agents):
        state = lookahead.state_of(output.obs[robot], robot)
        assert state.nodes == env.executor._nodes
        assert state.finished == list(output.info.finished)
        assert state.elapsed == pytest.approx(output.info.elapsed, abs=1e-3)
        assert state.step_index == 1
    # The rest of the episode from the resumed state is the original's rest.
    rest = []
    while not (output.done or output.truncated):
        actions, hidden = policy.act_team(output.obs, output.action_mask, hidden)
        rest.append([int(a) for a in actions])
        output = env.step(rest[-1])
    resumed = make_env(scenario, "embedded", profile="ideal", mask="finished")
    again = resumed.resume(state.nodes, state.finished, state.elapsed, state.step_index)
    assert again.info.finished == state.finished
    for joint in rest:
        again = resumed.step(joint)
    assert again.done and again.info.episode.logic_consistent
    assert again.info.elapsed == pytest.approx(output.info.elapsed, abs=1e-3)


@pytest.mark.slow
def test_lookahead_reaches_lab_3r_optimum_the_actor_alone_misses():
    scenario, policy, lookahead = bound(LAB / "lab_3r.xml")
    task = load_task_settings()
    optimum = solve_exact(scheduling_instance(scenario, task.min_step, task.goal_timeout))
    assert optimum.proven_optimal
    alone = episode(scenario, in_process_team(policy))
    team = in_process_team(policy, lookahead)
    looked = episode(scenario, team)
    assert alone.makespan > optimum.makespan + 1e-6          # the actor alone misses it
    assert looked.makespan == pytest.approx(optimum.makespan, abs=1e-6)
    assert team.name == "lookahead"


DATA = package_root() / "test" / "data" / "scenarios"
UNSEEN = [DATA / name for name in ("join_2r4t.xml", "chains_3r6t.xml", "turned_3r5t.xml", "lab_2r4t.xml")]


@pytest.mark.parametrize("path", UNSEEN, ids=lambda p: p.stem)
@pytest.mark.slow
def test_lookahead_is_never_longer_than_the_actors_own_episodes(path):
    """Rollout's guarantee: the search at each step starts from the episode the last step's found,
    so the team's episode is at most the shortest of the actor's own episodes (played as the
    search plays them) under the orientations; on turned_3r5t strictly shorter.
    The episode kept from the opening rollout plan is given up only for a shorter one, so the
    team's is at most the plan's too."""
    scenario, policy, lookahead = bound(path)
    first = make_env(scenario, "embedded", profile="ideal", mask="finished").reset(seed=0)
    alone = lookahead.episodes_alone(lookahead.state_of(first.obs[0], 0))
    assert len(alone) == 8 and all(math.isfinite(m) for m in alone)
    looked = episode(scenario, in_process_team(policy, lookahead)).makespan
    assert looked <= min(alone) + 1e-6
    assert lookahead.opening is not None and looked <= lookahead.opening.usable_makespan + 1e-6
    if path.stem == "turned_3r5t":
        assert looked < min(alone) - 1e-6


@pytest.mark.slow
def test_the_team_keeps_the_opening_rollout_plan_while_no_search_beats_it():
    """On chains_3r6t the rollout plan made at the first step is shorter than the episode the
    steps' searches alone end with, and it is kept to the end: no step's search finds a shorter one."""
    scenario, policy, searches_alone = bound(DATA / "chains_3r6t.xml", opening=None)
    searched = episode(scenario, in_process_team(policy, searches_alone)).makespan
    assert searches_alone.opening is None
    _, _, lookahead = bound(DATA / "chains_3r6t.xml")
    team = in_process_team(policy, lookahead)
    opened = episode(scenario, team).makespan
    assert lookahead.opening is not None and lookahead.opening_s > 0
    assert opened == pytest.approx(lookahead.opening.usable_makespan, abs=1e-6)
    assert opened < searched - 1e-6


@pytest.mark.slow
def test_with_a_precedence_margin_the_team_keeps_only_episodes_that_leave_it():
    """lab_4r's optimum under the step rules, 25.99 s, reaches a successor 0.23 s after its
    predecessor's finish: legs that run late (stock navigation) break its order. With a margin of
    1 s the robots' episode leaves at least that, at the margin's proven optimum (31.03 s)."""
    from marl_mrta.baselines.plan import simulate_joint_actions
    scenario = load_scenario(LAB / "lab_4r.xml")
    policy = load_policy("generalist").for_scenario(scenario)
    task = load_task_settings()
    budget = load_baseline_settings().lookahead
    thinnest = {}
    for margin in (0.0, 1.0):
        lookahead = Lookahead(policy, budget, None, margin)
        record = episode(scenario, in_process_team(policy, lookahead))
        instance = scheduling_instance(scenario, task.min_step, task.goal_timeout, margin)
        run = simulate_joint_actions(instance, record.joint_actions)
        assert run.complete and run.elapsed == pytest.approx(record.makespan, abs=1e-6)
        thinnest[margin] = run.thinnest_margin
        if margin:
            assert run.violations == 0 and "keeping a precedence margin of 1 s" in lookahead.describe()
            assert record.makespan == pytest.approx(solve_exact(instance).makespan, abs=1e-6)
    assert thinnest[0.0] < 1.0 <= thinnest[1.0]


def test_alternatives_zero_and_one_orientation_is_the_actor_alone():
    scenario, policy, lookahead = bound(LAB / "lab_3r.xml", alternatives=0, orientations=1, opening=None)
    alone = episode(scenario, in_process_team(policy))
    assert episode(scenario, in_process_team(policy, lookahead)).makespan == pytest.approx(alone.makespan)


@pytest.mark.slow
def test_evaluate_method_lookahead(tmp_path, capsys):
    out = tmp_path / "eval.json"
    assert evaluate_main(["--method", "policy,lookahead", "--policy", "generalist", "--scenario",
                          str(LAB / "lab_3r.xml"), "--episodes", "1", "--no-exact", "--quiet", "--out", str(out)]) == 0
    by_method = {r["summary"]["method"]: r for r in json.loads(out.read_text())["results"]}
    results = {method: r["summary"] for method, r in by_method.items()}
    assert results["lookahead"]["makespan_mean"] < results["policy"]["makespan_mean"] - 1e-6
    assert results["lookahead"]["logic_consistent_pct"] == 100.0
    # one search per step of the episode, shared by the robots (not one per robot)
    searched = re.search(r"lookahead: (\d+) steps searched", capsys.readouterr().err)
    assert searched and int(searched.group(1)) == by_method["lookahead"]["episodes"][0]["decision_steps"]


def test_lookahead_needs_a_set_actor(tmp_path, capsys):
    from marl_mrta.mappo.networks import Actor
    from marl_mrta.mappo.policy import save_actor
    lab_2r = str(LAB / "lab_2r.xml")
    env = make_env(lab_2r)
    mlp = tmp_path / "actor.pt"
    save_actor(mlp, Actor(env.obs_dim, env.n_actions, 16), obs_dim=env.obs_dim, n_agents=env.n_agents,
               append_agent_id=False, settings={}, scenario=lab_2r,
               predecessors=env.scenario.predecessors)
    code = evaluate_main(["--method", "lookahead", "--policy", str(mlp), "--scenario", lab_2r,
                          "--episodes", "1", "--no-exact", "--quiet", "--out", str(tmp_path / "e.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "lookahead" in err[0] and "set actor" in err[0], err
    assert not (tmp_path / "e.json").exists()


@pytest.mark.slow
def test_every_robot_finds_the_same_step_and_one_searches_again_around_a_robot_that_did_not():
    """The robots search alike, so the second in turn answers its part of the first's joint action;
    told that the first took that very task instead, it searches again with that choice fixed
    and answers another (a lookahead that ignored the claims would send both to one task)."""
    import numpy as np
    from marl_mrta.evaluation.robot_actor import RobotActor
    scenario, policy, lookahead = bound(LAB / "lab_3r.xml")
    first = make_env(scenario, "embedded", profile="ideal", mask="finished").reset(seed=0)
    order = [int(r) for r in policy.turns(first.obs)]
    mask = first.action_mask.astype(np.uint8)
    lead, second = order[0], order[1]
    led = RobotActor(policy, lead, lookahead).decide(0, 0, True, first.obs[lead], mask[lead], lead)
    claims = np.zeros(scenario.n_tasks, dtype=np.uint8)
    if led.action < scenario.n_tasks:
        claims[led.action] = lead + 1
    follower = RobotActor(policy, second, lookahead)
    planned = follower.decide(0, 0, True, first.obs[second], mask[second], second, claims.tobytes()).action
    assert follower.looked.play_outs == 0          # the joint action the lead's search found, shared in-process
    assert planned < scenario.n_tasks and planned != led.action
    other = np.zeros(scenario.n_tasks, dtype=np.uint8)
    other[planned] = lead + 1                      # the lead took the follower's planned task instead
    again = RobotActor(policy, second, lookahead).decide(0, 0, True, first.obs[second], mask[second], second,
                                                         other.tobytes())
    assert again.action != planned


def test_a_resumed_episode_refuses_a_state_that_does_not_fit_the_scenario():
    env = make_env(LAB / "lab_2r.xml", "embedded", profile="ideal", mask="finished")
    n_tasks = env.n_tasks
    with pytest.raises(ValueError, match="one node of the table per robot"):
        env.resume([0], [False] * n_tasks, 0.0, 0)
    with pytest.raises(ValueError, match="one node of the table per robot"):
        env.resume([0, 99], [False] * n_tasks, 0.0, 0)
    with pytest.raises(ValueError, match="finished: 3 flags"):
        env.resume([0, 1], [False] * 3, 0.0, 0)
    out = env.resume([2, 1], [True] + [False] * (n_tasks - 1), 12.5, 1)   # robot 0 at task 0's goal
    assert out.info.elapsed == 12.5 and out.info.finished[0] and not out.action_mask[0][0]
    assert env.executor.poses()[0] == env.executor.table.node_poses[2]


@pytest.mark.parametrize("value", ["soon", -1.0, "nan", "inf"])
def test_a_bad_precedence_margin_of_an_actor_node_is_one_line(value):
    from marl_mrta.apps.robot_actor_node import precedence_margin
    with pytest.raises(ValueError) as error:
        precedence_margin("/tb3_0/robot_actor", value, 0.0)
    assert "/tb3_0/robot_actor/precedence_margin" in str(error.value) and "\n" not in str(error.value)
    assert precedence_margin("/tb3_0/robot_actor", "", 0.25) == 0.25     # empty: config/task_baselines.yaml's
    assert precedence_margin("/tb3_0/robot_actor", 1, 0.0) == 1.0
