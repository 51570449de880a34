"""Sequential decisions with claimed tasks (mappo/claims.py): the rules, training, the team
actor and the per-robot actors (decentralised execution) agree."""
import numpy as np
import pytest
import torch

from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.mappo.claims import ClaimRules, claimed_flags, in_turn_filter, with_claims
from marl_mrta.mappo.config import ConfigError, config_from_dict
from marl_mrta.mappo.networks import Actor
from marl_mrta.mappo.policy import ActorPolicy, SetActorPolicy, load_policy
from marl_mrta.mappo.runner import Runner
from marl_mrta.mappo.set_view import SetView
from marl_mrta.mappo.training_env import set_view_pool
from marl_mrta.evaluation.training import on_new_env
from marl_mrta.evaluation.decentralised import ChoiceBoard, DecentralisedPolicy
from marl_mrta.evaluation.robot_actor import ObservationError, RobotActor
from marl_mrta.model.scenario import load_scenario
from marl_mrta.common.paths import package_root

LAB_4R = package_root() / "scenarios" / "lab_4r.xml"
NONE = 8   # lab_4r: 8 tasks, the None action is index 8


def task_index(scenario, task_id):
    return [t.id for t in scenario.tasks].index(task_id)


def test_claimed_flags_ignore_none_and_repeat():
    flags = claimed_flags(torch.tensor([[2, NONE, 5], [NONE, NONE, NONE]]), 8)
    assert flags.shape == (2, 8)
    assert flags[0].nonzero().flatten().tolist() == [2, 5]
    assert not flags[1].any()
    assert claimed_flags(torch.zeros(3, 0, dtype=torch.long), 8).shape == (3, 8)
    assert with_claims(torch.zeros(2, 5), flags).shape == (2, 13)


def test_sequential_rules_forbid_claimed_tasks_only():
    scenario = load_scenario(LAB_4R)
    rules = ClaimRules("sequential", scenario.predecessors)
    env_mask = torch.ones(NONE + 1, dtype=torch.bool)
    env_mask[3] = False                                   # finished before
    claimed = torch.zeros(8, dtype=torch.bool)
    claimed[[0, 6]] = True
    mask = rules.mask(env_mask, claimed)
    assert mask.tolist() == [False, True, True, False, True, True, False, True, True]


def test_sequential_logic_opens_a_successor_of_a_claimed_task():
    scenario = load_scenario(LAB_4R)
    a1, b1, b2 = (task_index(scenario, t) for t in ("A1", "B1", "B2"))
    assert list(scenario.predecessors[b1]) == [a1]
    rules = ClaimRules("sequential_logic", scenario.predecessors)
    open_all = torch.ones(NONE + 1, dtype=torch.bool)        # `finished` mask at the episode start
    nobody = torch.zeros(8, dtype=torch.bool)
    first = rules.mask(open_all, nobody)
    assert not first[b1] and first[a1] and first[NONE]
    a1_claimed = nobody.clone()
    a1_claimed[a1] = True
    second = rules.mask(open_all, a1_claimed)
    assert second[b1] and not second[a1] and not second[b2]
    # idempotent: the orchestrator sends the narrowed mask and the actor applies the rules again
    assert torch.equal(rules.mask(second, a1_claimed), second)
    a1_finished = open_all.clone()
    a1_finished[a1] = False
    assert rules.mask(a1_finished, nobody)[b1]


def test_sequential_logic_needs_the_finished_mask():
    with pytest.raises(ConfigError, match="action_mask"):
        config_from_dict({"decision_order": "sequential_logic", "action_mask": "logic"}, "preset.yaml")
    with pytest.raises(ConfigError, match="decision_order"):
        config_from_dict({"decision_order": "in_turn"}, "preset.yaml")
    # turns by the nearest ready task are read from the set actor's rows, in a sequential decision
    with pytest.raises(ConfigError, match="turn_order"):
        config_from_dict({"decision_order": "sequential", "turn_order": "nearest_ready"}, "preset.yaml")
    with pytest.raises(ConfigError, match="turn_order"):
        config_from_dict({"actor": "set", "append_agent_id": False, "turn_order": "nearest_ready"}, "preset.yaml")
    with pytest.raises(ConfigError, match="turn_order"):
        config_from_dict({"turn_order": "farthest"}, "preset.yaml")
    assert config_from_dict({"actor": "set", "append_agent_id": False, "decision_order": "sequential",
                             "turn_order": "nearest_ready"}).turn_order == "nearest_ready"


def small_config(**extra):
    values = {"n_envs": 4, "total_env_steps": 160, "batch_size": 80, "minibatch_size": 80, "chunk_length": 10,
              "hidden_size": 16, "eval_every": 0, "eval_episodes": 2, "action_mask": "finished",
              "decision_order": "sequential_logic", "learning_rate": 1e-3}
    values.update(extra)
    return config_from_dict(values)


def test_training_never_gives_a_task_twice_in_a_step(tmp_path):
    """Every joint action sampled while collecting names each task at most once, and B tasks
    only after their A task is finished or claimed (would fail with simultaneous decisions,
    which sample duplicates from an untrained actor)."""
    scenario = load_scenario(LAB_4R)
    build = lambda: make_env(LAB_4R, "embedded", mask="finished")  # noqa: E731
    runner = Runner(small_config(), build, evaluate=on_new_env(build), scenario="lab_4r",
                    seed=0, out_dir=tmp_path, tensorboard=False, plots=False)
    runner.start()
    runner.collect()
    actions = runner.buffer.actions.reshape(-1, 4).tolist()
    assert len(actions) == 80
    for joint in actions:
        tasks = [a for a in joint if a != NONE]
        assert len(tasks) == len(set(tasks)), joint
    # the sampled B tasks at the first step of the first episodes come with their A task claimed
    first = runner.buffer.actions[0].reshape(-1, 4).tolist()
    for joint in first:
        for robot, task in enumerate(joint):
            for pred in scenario.predecessors[task] if task != NONE else []:
                assert pred in joint[:robot], joint
    # the actor input carries the claimed flags: its width is obs + 8 tasks + 4 robot ids
    assert runner.buffer.obs.shape[-1] == runner.pool.obs_dim + 8 + 4


@pytest.mark.parametrize("actor,turn_order", [("mlp", "index"), ("set", "index"), ("set", "nearest_ready")])
@pytest.mark.slow
def test_team_actor_and_per_robot_actors_decide_alike(tmp_path, actor, turn_order):
    """act_team (evaluation) and the robots' own actors, asked in turn with the claimed tasks
    (DecentralisedPolicy), give the same episodes; an actor file keeps the claim rules and the
    turn order. The set actor (mappo/set_networks.py) reads who claimed what (the claimer's leg):
    the marks reach the robots' own actors too. With turns by the nearest ready task, the
    orchestrator asks the robots in the order their own rows give (as rl_manager does)."""
    scenario = load_scenario(LAB_4R)
    build = lambda: make_env(LAB_4R, "embedded", mask="finished")  # noqa: E731
    if actor == "set":
        config = small_config(actor="set", append_agent_id=False, set_heads=2, set_layers=1, turn_order=turn_order)
        pool = set_view_pool(config, [LAB_4R], seed=1)
    else:
        config, pool = small_config(), None
    runner = Runner(config, build, evaluate=on_new_env(build), scenario="lab_4r", seed=1,
                    out_dir=tmp_path, tensorboard=False, plots=False, pool=pool)
    runner.start()
    runner.train_one_update()
    runner.save_checkpoint()
    policy = load_policy(tmp_path / "actor.pt", scenario=scenario)
    assert policy.sequential and policy.decision_order == "sequential_logic" and policy.turn_order == turn_order
    assert isinstance(policy, SetActorPolicy) == (actor == "set")

    class Team:
        name = "team"

        def begin_episode(self, first, episode=None):
            self.hidden = policy.initial_hidden(4)

        def act(self, output):
            actions, self.hidden = policy.act_team(output.obs, output.action_mask, self.hidden)
            return [int(a) for a in actions]

    central = run_episodes(make_env(LAB_4R, "embedded", mask="finished"), Team(), episodes=3, seed=7)
    board = ChoiceBoard([r.id for r in scenario.robots])
    actors = [RobotActor(policy, i) for i in range(4)]
    asked = []

    def send(i, row):
        asked.append((i, row.claimed.tolist()))
        decision = actors[i].decide(row.episode, row.step, row.episode_start, row.obs, row.action_mask.tobytes(),
                                    row.agent_index, row.claimed.tobytes())
        board.offer(i, decision.episode, decision.step, decision.action)

    decentral = run_episodes(make_env(LAB_4R, "embedded", mask="finished"),
                             DecentralisedPolicy(4, send, board, timeout=5.0,
                                                 claim_rules=ClaimRules(policy.decision_order, scenario.predecessors),
                                                 turns=None if turn_order == "index"
                                                 else SetView(scenario, turn_order).turns),
                             episodes=3, seed=7)
    assert [r.robot_task_lists() for r in decentral] == [r.robot_task_lists() for r in central]
    assert [r.makespan for r in decentral] == [r.makespan for r in central]
    first_turns = [0, 1, 2, 3] if turn_order == "index" else \
        SetView(scenario, turn_order).turns(build().reset(seed=7).obs).tolist()
    assert first_turns != [0, 1, 2, 3] or turn_order == "index"
    assert [i for i, _ in asked[:4]] == first_turns         # in turn
    assert sum(asked[0][1]) == 0 and sum(asked[3][1]) >= 1  # the last robot hears of earlier claims
    for record in central:
        for joint in record.joint_actions:
            tasks = [t for t in joint if t is not None]
            assert len(tasks) == len(set(tasks))


def test_claims_sent_to_a_simultaneous_actor_are_refused():
    env = make_env(LAB_4R, "embedded", mask="finished")
    torch.manual_seed(0)
    policy = ActorPolicy(Actor(env.obs_dim + 4, env.n_actions, 8), obs_dim=env.obs_dim, n_agents=4,
                         append_agent_id=True, settings={"action_mask": "finished"})
    first = env.reset(seed=0)
    actor = RobotActor(policy, 0)
    with pytest.raises(ObservationError, match="claimed"):
        actor.decide(0, 0, True, first.obs[0], first.action_mask[0].astype(np.uint8).tobytes(), 0, bytes(8))
    with pytest.raises(ObservationError, match="claimed"):
        actor.decide(0, 0, True, first.obs[0], first.action_mask[0].astype(np.uint8).tobytes(), 0, bytes(3))


@pytest.mark.parametrize("decision_order", ["sequential", "sequential_logic"])
def test_allowed_joint_actions_are_those_decide_in_turn_offers(decision_order):
    scenario = load_scenario(LAB_4R)
    rules = ClaimRules(decision_order, scenario.predecessors)
    n_robots, n_tasks = scenario.n_robots, scenario.n_tasks
    actions = torch.cartesian_prod(*[torch.arange(n_tasks + 1)] * n_robots)          # every joint action
    finished = torch.tensor([True, False, False, True, False, False, False, False])    # A1 and A4 done
    env_mask = torch.cat([~finished, torch.tensor([True])]).expand(n_robots, -1)
    def offered_in(order):
        offered = torch.ones(len(actions), dtype=torch.bool)

        def decide(robot, claimed, mask):
            nonlocal offered
            choice = actions.gather(1, robot.unsqueeze(1)).squeeze(1)
            offered = offered & mask.gather(-1, choice.unsqueeze(-1)).squeeze(-1)
            return choice
        chosen = rules.decide_in_turn(env_mask.expand(len(actions), -1, -1), decide,
                                      None if order is None else torch.tensor(order).expand(len(actions), -1))
        assert torch.equal(chosen, actions)       # each robot's action lands in its own column
        return offered
    allowed = rules.allowed(env_mask, actions, range(n_robots))
    assert torch.equal(allowed, offered_in(None))
    assert 0 < int(allowed.sum()) < len(actions)
    # Another order is the index order of the robots listed in that order, and decide_in_turn follows it.
    order = [2, 0, 3, 1]
    in_order = rules.allowed(env_mask, actions, order)
    assert torch.equal(in_order, rules.allowed(env_mask[order], actions[:, order], range(n_robots)))
    assert torch.equal(in_order, offered_in(order))
    # Only the precedence mask depends on who chooses first; no task given twice does not.
    assert torch.equal(in_order, allowed) == (decision_order == "sequential")


def test_the_exact_search_over_an_in_turn_order_finds_that_orders_best_schedule():
    from marl_mrta.baselines.exact import solve_exact
    from marl_mrta.baselines.plan import SchedulingInstance
    # Nodes: robots 0 and 1, task A (2), task B (3) after A. Robot 1 is next to A, robot 0 nearer
    # B: the optimum sends both at once (5 s), which robot 0 deciding first cannot choose (B is
    # closed to it while A is unclaimed): it waits a step for robot 1 to finish A (6 s).
    travel = np.array([[0.0, 9.0, 6.0, 5.0], [9.0, 0.0, 1.0, 8.0], [6.0, 1.0, 0.0, 10.0], [5.0, 8.0, 10.0, 0.0]])
    instance = SchedulingInstance(2, 2, travel, (0.0, 0.0), ((), (0,)), 1.0)
    assert solve_exact(instance).makespan == pytest.approx(5.0)
    robot_0_first = solve_exact(instance, allowed=in_turn_filter(instance, "sequential_logic", "index"))
    assert robot_0_first.proven_optimal and robot_0_first.makespan == pytest.approx(6.0)
    assert robot_0_first.joint_actions[0] == [None, 0]
    # robot 1 stands 1 s from A, the only ready task: it chooses first, and B opens to robot 0
    nearest_first = solve_exact(instance, allowed=in_turn_filter(instance, "sequential_logic", "nearest_ready"))
    assert nearest_first.proven_optimal and nearest_first.makespan == pytest.approx(5.0)
    assert nearest_first.joint_actions[0] == [1, 0]
