"""MAPPO and the learned policies in event mode: returns discounted by the time a transition takes,
robots that do not decide neither trained on nor changed, the generalist acting on events (zero-shot,
by rollout) and fine-tuned on them up to the event reference."""
from pathlib import Path

import pytest
import torch

from marl_mrta.apps.train import main as train_main
from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.policies import EventPlanPolicy, LearnedPolicy
from marl_mrta.evaluation.rollout import rollout_plan
from marl_mrta.evaluation.training import on_new_env
from marl_mrta.mappo.buffer import compute_gae
from marl_mrta.mappo.config import load_config, resolve_preset
from marl_mrta.mappo.policy import load_policy, read_actor_file
from marl_mrta.mappo.runner import Runner
from marl_mrta.mappo.training_env import embedded_factory

ROOT = Path(__file__).resolve().parents[2]
LAB_3R = ROOT / "scenarios" / "lab_3r.xml"


def test_returns_discount_each_transition_by_its_own_length():
    """One robot, three transitions of 2, 5 and 1 s with rewards 1, 2, 3, gamma per 10 s: the
    return of the first is 1 + g^0.5 * (2 + g^0.2 * 3) (λ = 1, no bootstrap at the end)."""
    gamma = 0.9
    discounts = torch.tensor([[[gamma ** 0.2]], [[gamma ** 0.5]], [[gamma ** 0.1]]])
    rewards = torch.tensor([[[1.0]], [[2.0]], [[3.0]]])
    zeros = torch.zeros_like(rewards)
    ended = torch.tensor([[[False]], [[False]], [[True]]])
    result = compute_gae(rewards, zeros, zeros, terminated=ended, episode_end=ended, gamma=discounts, gae_lambda=1.0)
    expected = 1.0 + gamma ** 0.2 * (2.0 + gamma ** 0.5 * 3.0)
    assert float(result.returns[0, 0, 0]) == pytest.approx(expected, rel=1e-6)
    # A number gives every step that one discount, as in the paper's synchronous steps.
    same = compute_gae(rewards, zeros, zeros, terminated=ended, episode_end=ended, gamma=gamma, gae_lambda=1.0)
    assert float(same.returns[0, 0, 0]) == pytest.approx(1.0 + gamma * (2.0 + gamma * 3.0), rel=1e-6)


def test_a_robot_that_does_not_decide_keeps_its_recurrent_state_and_is_not_trained_on(tmp_path):
    config = load_config(resolve_preset("tuned"), {"decision_mode": "event", "action_mask": "finished",
                                                   "total_env_steps": 400, "n_envs": 4, "batch_size": 40,
                                                   "minibatch_size": 40, "chunk_length": 10, "eval_every": 0})
    make_env_ = embedded_factory(str(LAB_3R), config)
    runner = Runner(config, make_env_, evaluate=on_new_env(make_env_), scenario=str(LAB_3R), seed=0,
                    out_dir=tmp_path / "run", log=lambda line: None)
    runner.start()
    runner.collect()
    buffer = runner.buffer
    assert not bool(buffer.acting.all()) and bool(buffer.acting.any())   # some robots drove on at some steps
    # Between two steps of one episode, a robot that did not decide carries its state unchanged.
    same = buffer.actor_hidden[1:][~buffer.acting[:-1] & ~buffer.episode_start[1:].unsqueeze(-1)]
    before = buffer.actor_hidden[:-1][~buffer.acting[:-1] & ~buffer.episode_start[1:].unsqueeze(-1)]
    assert same.numel() and torch.equal(same, before)
    # Discounts are γ^(Δt / discount_seconds): below 1, each its own.
    assert float(buffer.discounts.max()) <= 1.0 and len(torch.unique(buffer.discounts)) > 2


def test_the_generalist_acts_on_events_complete_and_in_order():
    """An actor trained in synchronous steps (the shipped generalist) works in event mode: its
    observation is the same, a busy robot shown where it comes free and its task claimed."""
    env = make_env(LAB_3R, decision_mode="event", mask="finished", seed=0)
    policy = LearnedPolicy.from_file("generalist", env.n_agents, env.obs_dim, env.n_actions, scenario=env.scenario)
    record = run_episode(env, policy, seed=0)
    assert record.complete and record.logic_consistent


def test_the_rollout_plan_on_events_is_never_longer_than_the_actor_alone():
    env = make_env(LAB_3R, decision_mode="event", mask="finished", seed=0)
    instance = scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout,
                                   decision_mode="event")
    actor = load_policy("generalist", scenario=env.scenario)
    plan = rollout_plan(actor, env.scenario, instance, load_baseline_settings().rollout, "finished")
    alone = plan.details["greedy_makespan"]
    assert plan.makespan <= alone + 1e-9
    record = run_episode(env, EventPlanPolicy(plan, env.n_agents, env.n_tasks), seed=0)
    assert record.makespan == pytest.approx(plan.makespan, abs=1e-6)   # the routes, carried out on events
    assert plan.makespan >= solve_reference(instance).lower_bound - 1e-6


@pytest.mark.slow
def test_fine_tuning_on_events_reaches_the_event_reference(tmp_path):
    out = tmp_path / "run"
    assert train_main(["--scenario", str(LAB_3R), "--decision-mode", "event", "--out", str(out),
                       "--set", "max_wall_seconds=30"], log=lambda line: None) == 0
    _, data = read_actor_file(out / "actor.pt")
    assert data["settings"]["decision_mode"] == "event"
    env = make_env(LAB_3R, decision_mode="event", mask="finished", seed=0)
    policy = LearnedPolicy.from_file(str(out / "actor.pt"), env.n_agents, env.obs_dim, env.n_actions,
                                     scenario=env.scenario)
    record = run_episode(env, policy, seed=0)
    instance = scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout,
                                   decision_mode="event")
    reference = solve_reference(instance)
    assert reference.proven_optimal
    assert record.logic_consistent and record.makespan <= reference.best_makespan + 1e-6
