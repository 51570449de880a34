"""The size-invariant set actor (`actor: set`, preset `set`): permutation equivariance, any scenario
size, the set view of observations, training across scenarios of different sizes, actor files,
`train --init` and `evaluate` with a set actor's file. (Decentralised execution: test_mappo_claims.py.)"""
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import torch

from marl_mrta.baselines.reference import scenario_reference
from marl_mrta.common.paths import package_root
from marl_mrta.env.factory import make_env
from marl_mrta.env.observation import ORIENTATIONS, ROBOT_FEATURES, TASK_FEATURES, SetLayout, feature, turn_ranks
from marl_mrta.env.settings import load_embedded_settings, load_task_settings
from marl_mrta.evaluation.training import greedy_episodes
from marl_mrta.mappo.claims import with_set_claims
from marl_mrta.mappo.config import config_from_dict, config_to_dict, load_config, resolve_preset
from marl_mrta.mappo.imitation import demonstrate, imitate
from marl_mrta.mappo.policy import PolicyFileError, SetActorPolicy, load_policy, save_set_actor
from marl_mrta.mappo.runner import RunError, Runner
from marl_mrta.mappo.set_networks import SetActor
from marl_mrta.mappo.set_view import SetView
from marl_mrta.mappo.training_env import run_overrides, set_view_pool
from marl_mrta.model.generator import ScenarioRequest, generate_scenario
from marl_mrta.model.scenario import load_scenario

SCENARIOS = package_root() / "scenarios"
LAB_2R, LAB_4R = SCENARIOS / "lab_2r.xml", SCENARIOS / "lab_4r.xml"
SIMULTANEOUS = {"action_mask": "finished", "decision_order": "simultaneous"}
IN_TURN = {"action_mask": "finished", "decision_order": "sequential_logic"}


def fresh_policy(settings, seed=0, hidden=16):
    torch.manual_seed(seed)
    return SetActorPolicy(SetActor(hidden, 2, 1), settings=settings, source="test")


def permuted_copy(tmp_path, source, robot_order, task_order):
    """The scenario with its robots and tasks listed in another order (the same poses and precedence)."""
    tree = ET.parse(source)
    root = tree.getroot()
    map_element = root.find("map")
    map_element.set("file", str((Path(source).parent / map_element.get("file")).resolve()))
    for tag, order in (("robots", robot_order), ("tasks", task_order)):
        parent = root.find(tag)
        children = list(parent)
        for child in children:
            parent.remove(child)
        for index in order:
            parent.append(children[index])
    path = tmp_path / f"permuted_{Path(source).name}"
    tree.write(path)
    return path


def probabilities(policy, output, robot, claimed=None):
    hidden = policy.initial_hidden(1)
    logits, _, _ = policy.logits(output.obs[robot:robot + 1], output.action_mask[robot:robot + 1], hidden,
                                 agent_ids=[robot], claimed=None if claimed is None else claimed[None])
    return torch.softmax(logits[0], dim=-1).numpy()


def test_the_network_permutes_logits_with_the_tasks_and_ignores_the_robots_order():
    torch.manual_seed(1)
    actor = SetActor(16, 2, 2)
    layout = SetLayout(3, 6)
    rows = torch.rand(5, layout.width)
    own, robots, tasks, travel = layout.split(rows)
    robots[..., 0] = 1.0                    # valid
    robots[..., 1] = 0.0
    robots[:, 0, 1] = 1.0                   # robot slot 0 is the robot itself
    tasks[..., feature(TASK_FEATURES, "valid")] = 1.0
    mask = torch.rand(5, 7) > 0.3
    mask[:, -1] = True
    hidden = torch.zeros(5, 16)
    start = torch.ones(1, 5, dtype=torch.bool)
    reference = actor(rows[None], hidden, start, mask[None]).logits[0]

    task_perm = torch.tensor([4, 2, 5, 0, 1, 3])
    robot_perm = torch.tensor([2, 0, 1])

    def rebuild(own, robots, tasks, travel):
        return torch.cat([own, robots.reshape(5, -1), tasks.reshape(5, -1), travel.reshape(5, -1)], dim=-1)

    moved_tasks = rebuild(own, robots, tasks[:, task_perm], travel[:, :, task_perm])
    moved_mask = torch.cat([mask[:, :6][:, task_perm], mask[:, 6:]], dim=-1)
    logits = actor(moved_tasks[None], hidden, start, moved_mask[None]).logits[0]
    assert torch.allclose(torch.softmax(logits, -1)[:, :6], torch.softmax(reference, -1)[:, :6][:, task_perm], atol=1e-6)
    assert torch.allclose(torch.softmax(logits, -1)[:, 6], torch.softmax(reference, -1)[:, 6], atol=1e-6)

    moved_robots = rebuild(own, robots[:, robot_perm], tasks, travel[:, robot_perm])
    logits = actor(moved_robots[None], hidden, start, mask[None]).logits[0]
    assert torch.allclose(torch.softmax(logits, -1), torch.softmax(reference, -1), atol=1e-6)


def test_a_scenario_listed_in_another_order_gets_the_same_action_distribution(tmp_path):
    """End to end (observation rows -> set view -> network): lab_4r with its robots and tasks listed
    in another order; every robot gets the same probabilities over the same task goals, also in
    turn with tasks claimed before it."""
    robot_order, task_order = [2, 0, 3, 1], [5, 7, 0, 2, 6, 1, 4, 3]
    permuted = permuted_copy(tmp_path, LAB_4R, robot_order, task_order)
    original_env, permuted_env = make_env(LAB_4R, mask="finished"), make_env(permuted, mask="finished")
    original = fresh_policy(SIMULTANEOUS).for_scenario(original_env.scenario)
    moved = fresh_policy(SIMULTANEOUS).for_scenario(permuted_env.scenario)
    original_env.reset(seed=0)
    permuted_env.reset(seed=0)
    # a step taken first, so that some tasks are finished and robots stand on task goals
    first = original_env.step([0, 2, 8, 8])
    second = permuted_env.step([task_order.index([0, 2][robot_order[i]]) if robot_order[i] < 2 else 8
                                for i in range(4)])
    for robot in range(4):
        p = probabilities(original, first, robot)
        q = probabilities(moved, second, robot_order.index(robot))
        np.testing.assert_allclose(q[:8], p[:8][task_order], atol=1e-5)
        assert q[8] == pytest.approx(p[8], abs=1e-5)
    # tasks alone permuted: in turn with claims as well
    permuted_tasks = permuted_copy(tmp_path, LAB_4R, [0, 1, 2, 3], task_order)
    original_env, permuted_env = make_env(LAB_4R, mask="finished"), make_env(permuted_tasks, mask="finished")
    original = fresh_policy(IN_TURN).for_scenario(original_env.scenario)
    moved = fresh_policy(IN_TURN).for_scenario(permuted_env.scenario)
    first, second = original_env.reset(seed=0), permuted_env.reset(seed=0)
    claimed = np.zeros(8, dtype=bool)
    claimed[[0, 2]] = True
    p = probabilities(original, first, 2, claimed)
    q = probabilities(moved, second, 2, claimed[task_order])
    np.testing.assert_allclose(q[:8], p[:8][task_order], atol=1e-5)
    assert q[8] == pytest.approx(p[8], abs=1e-5)


def test_turns_by_the_nearest_ready_task_follow_the_robots_not_their_listing(tmp_path):
    """turn_order nearest_ready: the robot with the shortest leg to a ready task chooses first
    (ties by index), so the team's in-turn decision is the same whatever order the scenario lists
    its robots and tasks in; with index turns, robot 0 chooses first whatever its legs."""
    travel = np.array([[[3.0, 1.0, 9.0], [2.0, 5.0, 0.5], [2.0, 7.0, 7.0]]])     # (1, robots, tasks)
    ready = np.array([[True, True, False]])
    assert turn_ranks("nearest_ready", travel, ready).tolist() == [[0, 1, 2]]
    assert turn_ranks("nearest_ready", travel, np.array([[True, False, True]])).tolist() == [[2, 0, 1]]
    assert turn_ranks("index", travel, ready).tolist() == [[0, 1, 2]]
    nearest = {**IN_TURN, "turn_order": "nearest_ready"}
    robot_order, task_order = [2, 0, 3, 1], [5, 7, 0, 2, 6, 1, 4, 3]
    permuted = permuted_copy(tmp_path, LAB_4R, robot_order, task_order)
    original_env, permuted_env = make_env(LAB_4R, mask="finished"), make_env(permuted, mask="finished")
    original = fresh_policy(nearest).for_scenario(original_env.scenario)
    moved = fresh_policy(nearest).for_scenario(permuted_env.scenario)
    first, second = original_env.reset(seed=0), permuted_env.reset(seed=0)
    first, second = original_env.step([0, 8, 8, 8]), permuted_env.step([8, task_order.index(0), 8, 8])
    turns = original.view.turns(first.obs).tolist()
    assert turns[0] != 0                                  # robot 0 stands on A1, finished: not nearest
    assert moved.view.turns(second.obs).tolist() == [robot_order.index(r) for r in turns]
    for step in range(3):
        joint, _ = original.act_team(first.obs, first.action_mask, original.initial_hidden(4))
        joint_moved, _ = moved.act_team(second.obs, second.action_mask, moved.initial_hidden(4))
        none = 8
        assert [none if a == none else task_order.index(a) for a in joint[robot_order]] == joint_moved.tolist()
        first, second = original_env.step(joint.tolist()), permuted_env.step(joint_moved.tolist())
        if first.done:
            break


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """Scenarios from the generator at the ends of its range and in between."""
    out = tmp_path_factory.mktemp("generated")
    model = load_embedded_settings().travel
    sizes = [(2, 4, "rooms"), (16, 32, "pillars"), (7, 19, "corridors")]
    return [generate_scenario(ScenarioRequest(n_robots=n, n_tasks=m, layout=layout, width=12.0, height=10.0),
                              seed=3, out_dir=out, travel_model=model) for n, m, layout in sizes]


def test_one_actor_acts_on_scenarios_of_2_to_16_robots_and_4_to_32_tasks(generated):
    policy = fresh_policy(IN_TURN)
    for scenario in generated:
        env = make_env(scenario, mask="finished")
        bound = policy.for_scenario(scenario)
        out = env.reset(seed=0)
        hidden = bound.initial_hidden(scenario.n_robots)
        for _ in range(3):
            actions, hidden = bound.act_team(out.obs, out.action_mask, hidden)
            assert actions.shape == (scenario.n_robots,)
            tasks = [a for a in actions if a != scenario.n_tasks]
            assert len(tasks) == len(set(tasks))                       # in turn: never a task twice
            assert all(out.action_mask[i, a] for i, a in enumerate(actions))
            out = env.step(actions)
            if out.done or out.truncated:
                break


def test_set_rows_claims_and_padding():
    env = make_env(LAB_4R, mask="finished")
    policy = fresh_policy(IN_TURN).for_scenario(env.scenario)
    out = env.reset(seed=0)
    rows = torch.as_tensor(policy.view.rows(out.obs, range(4), sequential=True))
    layout = policy.view.layout
    assert rows.shape == (4, layout.width)
    claimed = torch.zeros(4, 8, dtype=torch.bool)
    claimed[3, 0] = True
    marked = with_set_claims(rows, claimed)
    _, _, tasks, travel = layout.split(marked)
    assert tasks[3, 0, feature(TASK_FEATURES, "claimed")] == 1.0 and tasks[:3, :, feature(TASK_FEATURES, "claimed")].sum() == 0
    # the likely claimer's leg: the nearest robot that decided before robot 3
    assert tasks[3, 0, feature(TASK_FEATURES, "claim_leg")] == pytest.approx(float(travel[3, :3, 0].min()))
    bigger = SetLayout(6, 11)
    padded = layout.pad(rows.numpy(), bigger)
    own, robots, tasks, _ = bigger.split(padded)
    assert robots[:, 4:].sum() == 0 and tasks[:, 8:].sum() == 0
    np.testing.assert_array_equal(bigger.split(padded)[3][:, :4, :8], layout.split(rows.numpy())[3])


def test_a_turned_floor_turns_the_offsets_alone():
    """The rows of the floor turned by 90 degrees (ORIENTATIONS[1]) and mirrored on x (4): every
    feature as on the floor as it is but the offsets dx, dy, which are turned; the turn order too."""
    env = make_env(LAB_4R, mask="finished")
    policy = fresh_policy(IN_TURN).for_scenario(env.scenario)
    out = env.reset(seed=0)
    out = env.step([0, 2, 4, 6])
    as_it_is = policy.view.rows(out.obs, range(4), sequential=True)
    layout = policy.view.layout
    offsets = [(SetLayout.n_self, ROBOT_FEATURES, layout.robot_slots), (layout.at_tasks, TASK_FEATURES, layout.task_slots)]
    for orientation, expected in ((1, lambda dx, dy: (-dy, dx)), (4, lambda dx, dy: (dx, -dy))):
        turned = policy.turned(orientation)
        rows = turned.view.rows(out.obs, range(4), sequential=True)
        changed = np.flatnonzero((rows != as_it_is).any(axis=0))
        columns = set()
        for start, names, slots in offsets:
            for slot in range(slots):
                at = start + slot * len(names)
                dx, dy = as_it_is[:, at + feature(names, "dx")], as_it_is[:, at + feature(names, "dy")]
                want_x, want_y = expected(dx, dy)
                np.testing.assert_allclose(rows[:, at + feature(names, "dx")], want_x, atol=1e-6)
                np.testing.assert_allclose(rows[:, at + feature(names, "dy")], want_y, atol=1e-6)
                columns |= {at + feature(names, "dx"), at + feature(names, "dy")}
        assert len(changed) > 0 and set(changed) <= columns
        torch.testing.assert_close(turned.turns(out.obs), policy.turns(out.obs))
    assert len(ORIENTATIONS) == 8 and len({tuple(m.ravel()) for m in ORIENTATIONS}) == 8
    assert all(np.allclose(m @ m.T, np.eye(2)) for m in ORIENTATIONS)
    np.testing.assert_array_equal(policy.turned(0).view.rows(out.obs, range(4), True), as_it_is)
    with pytest.raises(ValueError):
        policy.turned(8)


def test_training_across_scenarios_of_different_sizes_pads_and_keeps_the_rules(tmp_path):
    """One pool over lab_2r and lab_4r (padded to 4 robots): every sampled joint action is valid for
    its own scenario, padded robots only ever choose None, and a seeded run repeats bit for bit."""
    config = config_from_dict({"actor": "set", "append_agent_id": False, "hidden_size": 16, "set_heads": 2,
                               "set_layers": 1, "n_envs": 4, "batch_size": 80, "minibatch_size": 80,
                               "chunk_length": 10, "total_env_steps": 160, "eval_every": 0, **IN_TURN})

    def run(out):
        pool = set_view_pool(config, [LAB_2R, LAB_4R], seed=0)
        runner = Runner(config, None, evaluate=lambda actor, seeds: [], scenario="mixed", seed=0, out_dir=out,
                        tensorboard=False, plots=False, pool=pool)
        runner.start()
        runner.train_one_update()
        return runner

    runner = run(tmp_path / "a")
    assert runner.pool.mixed and runner.pool.n_agents == 4 and runner.pool.n_actions == 9
    actions, masks = runner.buffer.actions, runner.buffer.action_mask
    assert bool(torch.gather(masks, -1, actions.unsqueeze(-1)).all())
    two_robot_rows = ~masks[..., 2, :8].any(-1)          # robot slot 2 has no task: a lab_2r episode
    assert two_robot_rows.any() and (~two_robot_rows).any()
    assert (actions[..., 2:][two_robot_rows] == 8).all()
    for joint in actions.reshape(-1, 4).tolist():
        tasks = [a for a in joint if a != 8]
        assert len(tasks) == len(set(tasks))
    again = run(tmp_path / "b")
    assert torch.equal(runner.buffer.actions, again.buffer.actions)
    for a, b in zip(runner.trainer.actor.parameters(), again.trainer.actor.parameters()):
        assert torch.equal(a, b)


def test_matched_time_costs_make_driving_and_waiting_cost_the_same():
    scenario = load_scenario(LAB_2R)
    config = config_from_dict({"match_time_costs": True, "reward_overrides": {"nav": {"best": 0.0}, "idle": {"per_second": -0.5}}})
    slope = run_overrides(scenario, config)["nav"]["slope"]
    assert 0.35 * slope / scenario.nav_thresholds.t_avg == pytest.approx(0.2 * 0.5)


SMALL_SET = {"hidden_size": 16, "set_heads": 2, "set_layers": 1}


def saved_set_actor(path, seed=0):
    """A set actor of SMALL_SET's shape with seeded weights, saved to `path`; its weights."""
    torch.manual_seed(seed)
    actor = SetActor(SMALL_SET["hidden_size"], SMALL_SET["set_heads"], SMALL_SET["set_layers"])
    save_set_actor(path, actor, settings=dict(IN_TURN), trained_on="test")
    return actor.state_dict()


def same_weights(a, b):
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_set_actor_files_round_trip_and_bad_files_are_one_line(tmp_path):
    weights = saved_set_actor(tmp_path / "actor.pt")
    policy = load_policy(tmp_path / "actor.pt")
    assert isinstance(policy, SetActorPolicy) and policy.view is None and policy.decision_order == "sequential_logic"
    assert same_weights(policy.actor.state_dict(), weights)
    bound = load_policy(tmp_path / "actor.pt", scenario=load_scenario(LAB_4R))
    assert bound.n_agents == 4 and bound.n_actions == 9
    with pytest.raises(PolicyFileError, match="missing.pt: no such file"):
        load_policy(tmp_path / "missing.pt")
    (tmp_path / "junk.pt").write_text("not an actor")
    with pytest.raises(PolicyFileError, match="not a readable actor file"):
        load_policy(tmp_path / "junk.pt")
    # an empty name (a launch's policy:= left out) and a run directory say what they are
    with pytest.raises(PolicyFileError, match="^policy: empty: give an actor file"):
        load_policy("")
    with pytest.raises(PolicyFileError, match="a directory, not an actor file"):
        load_policy(tmp_path)


def test_init_starts_a_run_from_a_set_actor_file(tmp_path, capsys):
    """train --preset set --init ACTOR.pt: the run starts from the file's weights (new weights
    without it); with critic_warmup_updates covering the run, the actor it writes is that one."""
    from marl_mrta.apps.train import main as train_main
    weights = saved_set_actor(tmp_path / "start.pt", seed=5)
    config = config_from_dict({"actor": "set", "append_agent_id": False, **SMALL_SET, **IN_TURN})
    pool = set_view_pool(config, [LAB_2R], 0)
    started = Runner(config, None, evaluate=lambda actor, seeds: [], scenario="lab_2r", seed=0, out_dir=tmp_path / "r",
                     tensorboard=False, plots=False, pool=pool, init_actor=str(tmp_path / "start.pt"))
    assert same_weights(started.trainer.actor.state_dict(), weights)
    fresh = Runner(config, None, evaluate=lambda actor, seeds: [], scenario="lab_2r", seed=0, out_dir=tmp_path / "f",
                   tensorboard=False, plots=False, pool=set_view_pool(config, [LAB_2R], 0))
    assert not same_weights(fresh.trainer.actor.state_dict(), weights)
    # the file keeps its turn order: a run taking turns otherwise is refused, naming the key
    nearest = config_from_dict({"actor": "set", "append_agent_id": False, **SMALL_SET, **IN_TURN,
                                "turn_order": "nearest_ready"})
    with pytest.raises(RunError, match="turn_order=index"):
        Runner(nearest, None, evaluate=lambda actor, seeds: [], scenario="lab_2r", seed=0, out_dir=tmp_path / "n",
               tensorboard=False, plots=False, pool=set_view_pool(nearest, [LAB_2R], 0),
               init_actor=str(tmp_path / "start.pt"))

    settings = [f"{key}={value}" for key, value in {**SMALL_SET, "n_envs": 4, "batch_size": 80, "minibatch_size": 80,
                                                     "total_env_steps": 80, "critic_warmup_updates": 1,
                                                     "eval_every": 0, "eval_episodes": 1}.items()]
    args = ["--scenario", str(LAB_2R), "--preset", "set", "--init", str(tmp_path / "start.pt"),
            "--out", str(tmp_path / "run")] + [arg for s in settings for arg in ("--set", s)]
    assert train_main(args) == 0
    assert f"starting from {tmp_path / 'start.pt'}" in capsys.readouterr().out
    assert same_weights(load_policy(tmp_path / "run" / "actor.pt").actor.state_dict(), weights)


def test_bad_actor_files_and_backends_end_the_commands_with_one_line(tmp_path, capsys):
    from marl_mrta.apps.evaluate import main as evaluate_main
    from marl_mrta.apps.train import main as train_main
    (tmp_path / "junk.pt").write_text("not an actor")
    saved_set_actor(tmp_path / "small.pt")
    assert evaluate_main(["--method", "policy", "--policy", str(tmp_path / "missing.pt"), "--episodes", "1",
                          "--no-exact", "--quiet", "--out", str(tmp_path / "e.json")]) == 2
    assert "missing.pt: no such file" in capsys.readouterr().err
    assert evaluate_main(["--method", "policy", "--policy", str(tmp_path / "junk.pt"), "--episodes", "1",
                          "--no-exact", "--quiet", "--out", str(tmp_path / "e.json")]) == 2
    assert "not a readable actor file" in capsys.readouterr().err
    for preset, init, message in [("set", "missing.pt", "missing.pt: no such file"),
                                  ("tuned", "small.pt", "fine-tunes a run with actor: set"),
                                  ("set", "small.pt", "the actor has hidden_size, set_heads, set_layers (16, 2, 1)")]:
        assert train_main(["--preset", preset, "--init", str(tmp_path / init), "--out", str(tmp_path / preset),
                           "--set", "total_env_steps=40"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    assert train_main(["--preset", "set", "--backend", "ros", "--out", str(tmp_path / "ros")]) == 2
    assert "the set actor trains on the embedded backend" in capsys.readouterr().err


def test_evaluate_runs_one_set_actor_file_on_scenarios_of_any_size(tmp_path, generated):
    import json
    from marl_mrta.apps.evaluate import main as evaluate_main
    saved_set_actor(tmp_path / "actor.pt")
    for scenario in generated[0], generated[2]:
        out = tmp_path / f"{scenario.name}.json"
        assert evaluate_main(["--method", "policy", "--policy", str(tmp_path / "actor.pt"), "--scenario",
                              str(scenario.source), "--mask", "finished", "--episodes", "1", "--no-exact", "--quiet",
                              "--out", str(out)]) == 0
        summary = json.loads(out.read_text())["results"][0]["summary"]
        assert summary["method"] == "policy" and summary["episodes"] == 1 and summary["n_robots"] == scenario.n_robots


def proven_optimum(path):
    """The proven-optimal plan of the scenario as the embedded executor runs it."""
    task = load_task_settings()
    plan, _ = scenario_reference(make_env(path, mask="finished").scenario, task.min_step, goal_timeout=task.goal_timeout)
    assert plan.proven_optimal
    return plan


def greedy_makespan(policy, path):
    """The greedy episode's makespan (inf unless it finishes every task in order)."""
    record = greedy_episodes(policy, make_env(path, mask="finished"), [0])[0]
    return record.makespan if record.terminated and record.logic_consistent else float("inf")


@pytest.fixture(scope="module")
def imitated_lab_4r(tmp_path_factory):
    """A set actor of the `set` preset's shape that imitated lab_4r's proven-optimal plan
    (mappo/imitation.py, train_generalist's first stage), saved as an actor file; its path and the plan."""
    config = load_config(resolve_preset("set"))
    plan = proven_optimum(LAB_4R)
    env = make_env(LAB_4R, mask="finished")
    demo = demonstrate(env, SetView(env.scenario), plan.joint_actions, config.decision_order)
    assert demo.makespan == pytest.approx(plan.makespan)          # the replay is the plan
    torch.manual_seed(0)
    actor = SetActor(config.hidden_size, config.set_heads, config.set_layers)
    history = imitate(actor, [demo], epochs=100, learning_rate=5e-3, demos_per_batch=1, seed=0, log=lambda line: None)
    assert history[-1]["accuracy"] == 1.0 and history[-1]["loss"] < history[0]["loss"]
    path = tmp_path_factory.mktemp("imitated") / "lab_4r.pt"
    save_set_actor(path, actor, settings=config_to_dict(config), trained_on="imitation of lab_4r")
    return path, plan


def test_imitating_a_plan_reproduces_it(imitated_lab_4r):
    """The actor file of the imitation, run greedily in the training decision order, schedules
    lab_4r at the plan's (proven optimal) makespan."""
    path, plan = imitated_lab_4r
    assert greedy_makespan(load_policy(path), LAB_4R) == pytest.approx(plan.makespan, rel=1e-9)



@pytest.mark.slow
def test_train_generalist_stages_on_the_lab(tmp_path):
    """scripts/train_generalist's stages on lab_2r and lab_4r: cached teacher plans, imitation,
    then MAPPO across both scenarios from the imitated actor, checked on them."""
    import json
    from marl_mrta.apps.train_generalist import _imitation_stage, _mappo_stage, check, plans_for
    config = config_from_dict({"actor": "set", "append_agent_id": False, **SMALL_SET, **IN_TURN, "n_envs": 2,
                               "batch_size": 40, "minibatch_size": 40, "chunk_length": 10, "total_env_steps": 80,
                               "eval_every": 0})
    scenarios = [load_scenario(LAB_2R), load_scenario(LAB_4R)]
    lines = []
    plans = plans_for(scenarios, tmp_path / "plans.json", lines.append)
    assert len(lines) == 2 and set(json.loads((tmp_path / "plans.json").read_text())) == {"lab_2r.xml", "lab_4r.xml"}
    assert plans_for(scenarios, tmp_path / "plans.json", lines.append) == plans and len(lines) == 2   # cached
    actor, history = _imitation_stage(config, scenarios, plans, 40, 5e-3, 0, lambda line: None)
    assert history[-1]["accuracy"] > history[0]["accuracy"]
    references = [plan["makespan"] for plan in plans]
    imitated = check(SetActorPolicy(actor, settings=config_to_dict(config)), scenarios, references, "finished")
    save_set_actor(tmp_path / "start.pt", actor, settings=config_to_dict(config), trained_on="test")
    best, checks = _mappo_stage(config, scenarios, tmp_path / "start.pt", tmp_path, 0, scenarios, references, 1,
                                lambda line: None)
    assert [c["update"] for c in checks] == [0, 1, 2]
    assert {k: checks[0][k] for k in imitated} == imitated          # MAPPO starts from the imitated actor
    assert best["mean"] == min(c["mean"] for c in checks) and best["mean"] >= 1.0 - 1e-9
