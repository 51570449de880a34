"""Self-imitation (mappo/imitation.py, SelfImitation; config self_imitation_epochs): the best
sampled episode, taught to the actor until its greedy choice takes it."""
import pytest
import torch

from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.plan import under_either_rules
from marl_mrta.baselines.reference import scenario_reference, scheduling_instance, solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import package_root
from marl_mrta.env.factory import make_env
from marl_mrta.env.settings import load_task_settings
from marl_mrta.evaluation.training import greedy_episodes, offer_teacher_plan, on_new_env
from marl_mrta.mappo.config import config_from_dict, config_to_dict
from marl_mrta.mappo.imitation import SelfImitation
from marl_mrta.mappo.policy import SetActorPolicy
from marl_mrta.mappo.runner import Runner
from marl_mrta.mappo.set_networks import SetActor
from marl_mrta.mappo.set_view import SetView
from marl_mrta.mappo.training_env import embedded_factory, set_view_pool

LAB_2R, LAB_3R, LAB_4R = (package_root() / "scenarios" / f"{name}.xml" for name in ("lab_2r", "lab_3r", "lab_4r"))
SET_IN_TURN = {"actor": "set", "append_agent_id": False, "hidden_size": 16, "set_heads": 2, "set_layers": 1,
               "action_mask": "finished", "decision_order": "sequential_logic"}


def greedy_makespan(actor, settings, path):
    policy = SetActorPolicy(actor, settings=settings).for_scenario(make_env(path, mask="finished").scenario)
    record = greedy_episodes(policy, make_env(path, mask="finished"), [0])[0]
    return record.makespan if record.terminated and record.logic_consistent else float("inf")


def test_the_best_offered_episode_is_taught_until_the_greedy_policy_takes_it():
    """lab_4r's proven-optimal plan offered as a sampled episode (the pool's form: None is the
    last action), after a worse one: a new actor, whose greedy schedule is worse, then schedules
    at the plan's makespan. Nothing is taught once the greedy schedule is as short."""
    task = load_task_settings()
    env = make_env(LAB_4R, mask="finished")
    plan, _ = scenario_reference(env.scenario, task.min_step, goal_timeout=task.goal_timeout)
    assert plan.proven_optimal
    none = env.n_actions - 1
    as_sampled = [[none if a is None else a for a in joint] for joint in plan.joint_actions]
    settings = config_to_dict(config_from_dict(SET_IN_TURN))
    torch.manual_seed(3)
    actor = SetActor(16, 2, 1)
    before = greedy_makespan(actor, settings, LAB_4R)
    assert before > plan.makespan + 1e-6                     # there is something to learn

    learner = SelfImitation(epochs=300, learning_rate=5e-3, decision_order="sequential_logic")
    learner.offer(plan.makespan, 0, as_sampled)
    learner.offer(plan.makespan + 5.0, 0, as_sampled[::-1])   # longer: not kept
    learner.offer(plan.makespan - 5.0, None, as_sampled)      # no seed to replay it from: not kept
    assert learner.best_makespan == plan.makespan and learner.best_actions == as_sampled
    planned = SelfImitation(epochs=1, learning_rate=5e-3, decision_order="sequential_logic")
    assert planned.offer_plan(env, SetView(env.scenario), plan.joint_actions, "a plan") is None   # takeable: offered
    assert planned.best_actions == as_sampled and planned.best_makespan == pytest.approx(plan.makespan)
    assert learner.teach(actor, env, SetView(env.scenario), below=plan.makespan, seed=0) is None
    taught = learner.teach(actor, env, SetView(env.scenario), below=before, seed=0)
    assert taught is not None and taught["accuracy"] == 1.0
    assert taught["makespan"] == pytest.approx(plan.makespan)
    assert greedy_makespan(actor, settings, LAB_4R) == pytest.approx(plan.makespan, rel=1e-9)


@pytest.mark.slow
def test_a_run_with_self_imitation_evaluates_the_episode_it_imitated_and_checkpoints_it(tmp_path):
    """From new weights on lab_2r: the run imitates a sampled episode shorter than its greedy
    ones, and the next greedy evaluation is at most that long; the checkpoint keeps the episode."""
    config = config_from_dict({**SET_IN_TURN, "n_envs": 4, "batch_size": 80, "minibatch_size": 80,
                               "chunk_length": 10, "total_env_steps": 480, "eval_every": 1, "eval_episodes": 1,
                               "learning_rate": 2e-3, "self_imitation_epochs": 300, "self_imitation_lr": 5e-3})
    make = embedded_factory(LAB_2R, config)
    lines = []
    runner = Runner(config, make, evaluate=on_new_env(make), scenario=str(LAB_2R), seed=1, out_dir=tmp_path / "run",
                    log=lines.append, tensorboard=False, plots=False, pool=set_view_pool(config, [LAB_2R], 1))
    runner.start()
    runner.run()
    taught = [line for line in lines if "imitating a sampled episode of" in line]
    assert taught, lines
    evaluations = runner.history["evaluations"]
    for line in taught:
        update = int(line.split(":")[0].split()[1])
        makespan = float(line.split("episode of ")[1].split(" s")[0])
        assert evaluations[update - 1]["consistent_makespan"] <= makespan + 0.01
    stored = torch.load(runner.checkpoint_path, weights_only=True)["self_imitation"]
    assert stored["makespan"] == runner.self_imitation.best_makespan
    assert stored["actions"] == runner.self_imitation.best_actions


def test_self_imitation_needs_the_set_actor_and_an_embedded_scenario(tmp_path):
    """Settings that cannot work are refused naming the key; a run without an embedded
    environment to replay in (a simulation's arenas) trains without it and says so."""
    with pytest.raises(ConfigError, match="self_imitation_epochs"):
        config_from_dict({"self_imitation_epochs": 10})
    with pytest.raises(ConfigError, match="teacher"):
        config_from_dict({**SET_IN_TURN, "teacher": "ga"})
    config = config_from_dict({**SET_IN_TURN, "self_imitation_epochs": 10, "teacher": "ga"})
    lines = []
    runner = Runner(config, None, evaluate=lambda actor, seeds: [], scenario="lab_2r", seed=0, out_dir=tmp_path / "r",
                    log=lines.append, tensorboard=False, plots=False, pool=set_view_pool(config, [LAB_2R], 0))
    assert runner.self_imitation is None and any("self_imitation_epochs: off" in line for line in lines)


def _teacher_run(tmp_path, scenario, **settings):
    config = config_from_dict({**SET_IN_TURN, "self_imitation_epochs": 10, **settings})
    make = embedded_factory(scenario, config)
    runner = Runner(config, make, evaluate=on_new_env(make), scenario=str(scenario), seed=0, out_dir=tmp_path / "r",
                    log=lambda line: None, tensorboard=False, plots=False, pool=set_view_pool(config, [scenario], 0))
    runner.start()
    lines = []
    offer_teacher_plan(runner, lines.append)
    return runner, lines


def teacher_plans(runner):
    """The teacher's plans made again here as offer_teacher_plan makes them: the GA's (the run's
    seed) and the reference's with the GA's plan among its candidates (full budget)."""
    scenario = runner.replay_env()[0].scenario
    task = load_task_settings().for_scenario(scenario)   # the goal timeout the run plans with (site_8r's 60 s)
    instance = scheduling_instance(scenario, task.min_step, task.goal_timeout)
    settings = load_baseline_settings()
    ga = under_either_rules(lambda inst: solve_ga(inst, settings.ga, seed=runner.seed), instance)
    return ga, solve_reference(instance, settings, candidates=[ga]).plan


def as_sampled(runner, plan):
    """A plan's joint actions as self-imitation keeps an offered episode (None: the last action)."""
    none = runner.replay_env()[0].n_actions - 1
    return [[none if a is None else a for a in joint] for joint in plan.joint_actions]


def test_the_ga_teacher_offers_its_schedule_and_its_time_counts(tmp_path):
    """teacher: ga on lab_4r: the run's self-imitation holds the GA's schedule before any
    training, and its planning time is training wall time."""
    runner, _ = _teacher_run(tmp_path, LAB_4R, teacher="ga")
    ga, _ = teacher_plans(runner)
    assert runner.self_imitation.best_seed == 0
    assert runner.self_imitation.best_source == "the ga teacher's schedule"   # named so in the log
    # the GA's own schedule, replayed at its makespan
    assert runner.self_imitation.best_actions == as_sampled(runner, ga)
    assert runner.self_imitation.best_makespan == pytest.approx(ga.makespan)
    assert runner.wall_time > 0.0


@pytest.mark.slow
def test_the_reference_teacher_offers_the_best_known_plan_the_in_turn_decision_can_take(tmp_path):
    """teacher: reference offers evaluate's reference plan (lab_4r's proven optimum). On lab_3r
    that plan sends a robot to a task whose predecessor a robot after it in the turn order takes:
    sequential_logic with turns by the nearest ready task cannot produce it, so it is not offered
    and the log says which step; decision_order sequential can, and it is offered."""
    task = load_task_settings()
    runner, _ = _teacher_run(tmp_path / "4r", LAB_4R, teacher="reference")
    optimum, _ = scenario_reference(runner.replay_env()[0].scenario, task.min_step, goal_timeout=task.goal_timeout)
    assert runner.self_imitation.best_source == "the reference teacher's schedule"
    assert runner.self_imitation.best_makespan == pytest.approx(optimum.makespan)
    assert runner.wall_time > 0.0

    runner, lines = _teacher_run(tmp_path / "3r", LAB_3R, teacher="reference", turn_order="nearest_ready")
    _, best = teacher_plans(runner)
    assert best.proven_optimal
    assert runner.self_imitation.best_seed is None                      # nothing offered
    step = runner.offer_plan(best.joint_actions)                        # the step it cannot take
    assert step is not None and f"step {step + 1} " in lines[0]         # named in the log
    runner, _ = _teacher_run(tmp_path / "3r_sequential", LAB_3R, teacher="reference", turn_order="nearest_ready",
                             decision_order="sequential")
    # the same proven optimum, offered as it is
    assert runner.self_imitation.best_seed == 0 and runner.self_imitation.best_actions == as_sampled(runner, best)
    assert runner.self_imitation.best_makespan == pytest.approx(best.makespan)


@pytest.mark.slow
def test_a_reference_teacher_held_to_a_budget_is_never_longer_than_the_ga(tmp_path):
    """teacher_seconds holds the reference's solvers to a budget (BaselineSettings.within); the GA's
    plan is among its candidates, so a budget too small for CP-SAT to match it still offers it (site_8r:
    8 robots, CP-SAT serves). Without the GA among the candidates the plan offered was the auction's
    or a CP-SAT plan of a few milliseconds, longer than the GA's."""
    from marl_mrta.baselines.settings import CPSAT_MODELS

    settings = load_baseline_settings()
    held = settings.within(0.05)
    assert held.astar.time_limit == 0.025 and held.cpsat.time_limit == pytest.approx(0.025 / CPSAT_MODELS)
    assert settings.within(1e6) == settings
    site_8r = package_root() / "scenarios" / "site_8r.xml"
    runner, _ = _teacher_run(tmp_path, site_8r, teacher="reference", teacher_seconds=0.05,
                             decision_order="sequential")
    scenario = runner.replay_env()[0].scenario
    task = load_task_settings().for_scenario(scenario)   # the goal timeout the run plans with (site_8r's 60 s)
    instance = scheduling_instance(scenario, task.min_step, task.goal_timeout)
    ga = under_either_rules(lambda inst: solve_ga(inst, settings.ga, seed=0), instance)
    assert runner.self_imitation.best_seed == 0                 # a schedule was offered
    assert runner.self_imitation.best_makespan <= ga.makespan + 1e-6


def test_the_ga_plan_is_offered_where_the_in_turn_decision_cannot_take_the_best_known(tmp_path):
    """chains_3r6t (bench_generalise's test_001): the reference's optimum needs a step the in-turn
    decision (sequential, nearest ready first) cannot take; the GA's plan, as short, can, and is
    offered. Before, nothing was offered and a minute of fine-tuning ended out of precedence order."""
    scenario = package_root() / "test" / "data" / "scenarios" / "chains_3r6t.xml"
    runner, _ = _teacher_run(tmp_path, scenario, teacher="reference", decision_order="sequential",
                             turn_order="nearest_ready")
    ga, best = teacher_plans(runner)
    assert ga.makespan <= best.makespan + 1e-6                           # as short as the best known
    assert runner.self_imitation.best_actions == as_sampled(runner, ga)  # the GA's schedule, offered
    assert runner.self_imitation.best_makespan == pytest.approx(ga.makespan)
    assert runner.offer_plan(best.joint_actions) is not None             # the best known's: a step it cannot take
