"""Greedy evaluations of a policy in training (mappo/runner.py's `evaluate`), through the one
episode loop: on an environment of the run's factory, or in the run's own pool of environments
(arenas of a simulation, stepped in parallel)."""
from __future__ import annotations

import time
from functools import partial
from typing import Callable, List, Sequence

from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.plan import under_either_rules
from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.env.api import StepOutput, TaskAllocationEnv
from marl_mrta.env.settings import load_task_settings
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.policies import LearnedPolicy
from marl_mrta.mappo.env_pool import EnvPool, EpisodeSummary, EpisodeTally
from marl_mrta.mappo.policy import ActorPolicy
from marl_mrta.mappo.runner import GreedyEvaluation, Runner
from marl_mrta.model.event_rules import route_actions


def greedy_episodes(actor: ActorPolicy, env: TaskAllocationEnv, seeds: Sequence[int],
                    env_index: int = -1) -> List[EpisodeSummary]:
    """One greedy episode per seed on `env`, each summarised with its rewards."""
    policy = LearnedPolicy(actor.for_scenario(env.scenario), env.n_agents)
    summaries = []
    for seed in seeds:
        tally = EpisodeTally(env.n_agents)
        last = {}

        def book(out: StepOutput) -> None:
            tally.add(out)
            last["output"] = out

        run_episode(env, policy, int(seed), on_step=book)
        summaries.append(tally.summary(env_index, last["output"]))
    return summaries


def on_new_env(make_env: Callable[[], TaskAllocationEnv]) -> GreedyEvaluation:
    """Evaluations on a fresh environment of the factory each time."""
    return lambda actor, seeds: greedy_episodes(actor, make_env(), seeds)


def in_pool(pool: EnvPool) -> GreedyEvaluation:
    """Evaluations in the pool's environments: seed k on environment k mod n_envs, in parallel
    when the pool steps in parallel; the running training episodes are lost (the runner restarts them)."""
    def evaluate(actor: ActorPolicy, seeds: Sequence[int]) -> List[EpisodeSummary]:
        per_env = pool.map(lambda i: greedy_episodes(actor, pool.envs[i], seeds[i::pool.n_envs], env_index=i))
        return [per_env[k % pool.n_envs][k // pool.n_envs] for k in range(len(seeds))]
    return evaluate


def _route_actions(routes, none: int, out: StepOutput):
    deciding = out.deciding if out.deciding is not None else [True] * len(out.rewards)
    return route_actions(routes, out.info.finished, deciding, none)


def offer_teacher_plan(runner: Runner, log: Callable[[str], None] = print) -> None:
    """A fresh run's teacher (config teacher) plans the run's scenario, and its self-imitation
    gets the plan as if it had sampled it (mappo/imitation.py, SelfImitation)."""
    if runner.config.teacher == "none" or runner.self_imitation is None:
        return
    scenario = runner.replay_env()[0].scenario   # built once; self-imitation replays in it
    started = time.perf_counter()
    task = load_task_settings().for_scenario(scenario)   # the goal timeout the run's episodes have
    event = runner.config.decision_mode == "event"
    instance = scheduling_instance(scenario, task.min_step, task.goal_timeout,
                                   hold_successors=runner.config.hold_successors,
                                   decision_mode=runner.config.decision_mode)
    settings = load_baseline_settings()
    ga = under_either_rules(lambda inst: solve_ga(inst, settings.ga, seed=runner.seed), instance)
    plans = [ga]
    if runner.config.teacher == "reference":
        # The GA's plan is a candidate: the reference's budget may end before its solvers match it.
        budget = settings.within(runner.config.teacher_seconds) if runner.config.teacher_seconds > 0 else settings
        best = solve_reference(instance, budget, candidates=[ga]).plan
        plans = [best] + ([ga] if (ga.robot_tasks if event else ga.joint_actions) !=
                          (best.robot_tasks if event else best.joint_actions) else [])
    seconds = time.perf_counter() - started
    runner.wall_time += seconds   # planning is part of the run's training time
    plans = [plan for plan in plans if plan.complete and plan.logic_violations == 0]
    if not plans:
        log(f"teacher {runner.config.teacher}: no complete schedule in {seconds:.1f} s; nothing offered")
        return
    refused = []
    none = scenario.n_tasks
    for plan in plans:   # the best known first; the GA's when the in-turn decision cannot take it
        # Event mode: the plan's routes carried out as the episode's events come.
        actions = partial(_route_actions, plan.robot_tasks, none) if event else plan.joint_actions
        outside = runner.offer_plan(actions)
        if outside is None:
            log(f"teacher {runner.config.teacher}: {''.join(r + ' ' for r in refused)}a schedule of "
                f"{plan.makespan:.2f} s offered to self-imitation ({seconds:.1f} s)")
            return
        refused.append(f"step {outside + 1} of its {plan.makespan:.2f} s schedule is not one the in-turn decision "
                       f"({runner.config.decision_order}, turn order {runner.config.turn_order}) can take;")
    log(f"teacher {runner.config.teacher}: {' '.join(refused)} nothing offered (decision_order sequential leaves out "
        "fewer plans: docs/guide/training.md)")
