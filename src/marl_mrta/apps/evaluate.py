"""`evaluate`: run methods through the environment and print the paper's Tables 8–9.

    evaluate --method random,ga,auction,exact --scenario scenarios/lab_2r.xml --episodes 20 \
             --executor embedded --seed 0 --out results/eval_lab_2r.json
    evaluate --method exact --episodes 5 --executor ros     # through a running task manager (tasks.launch)
    evaluate --method policy,rollout --policy generalist --scenario my_floor.xml   # the actor, and its rollout plan
    evaluate --method policy,lookahead --policy generalist --scenario my_floor.xml # the robots' own decisions, alone and looking ahead
    evaluate --method replan,ga --decision-mode event --scenario live_floor.xml    # a live fleet's allocator beside a fixed plan

Writes the JSON (summaries, plans, the reference: best known makespan, proven lower bound and
gap, representative episodes) and one Gantt chart PNG per method (<out stem>_<method>_gantt.png).
Every solver runs within its budget (config/task_baselines.yaml; --time-limit, --workers); one
that reaches it says so in one line and its result counts as not proven. Bad input -> one
line, exit 2.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time
from pathlib import Path
from typing import Any, Dict, Optional, Sequence

from marl_mrta.baselines.auction import solve_auction
from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.plan import Plan, SchedulingInstance, simulate_joint_actions, under_either_rules
from marl_mrta.baselines.random_policy import RandomPolicy
from marl_mrta.baselines.reference import Reference, scheduling_instance, solve_reference
from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import package_root, runs_dir
from marl_mrta.common.results import write_result
from marl_mrta.env.factory import EXECUTORS, make_env
from marl_mrta.env.settings import DECISION_MODES, MASK_MODES
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.evaluation.policies import LearnedPolicy, PolicyLoadError, ReplanPolicy, plan_policy
from marl_mrta.evaluation.lookahead import Lookahead
from marl_mrta.evaluation.robot_actor import in_process_team
from marl_mrta.evaluation.rollout import RolloutError, rollout_plan
from marl_mrta.evaluation.summary import (ProgressLine, episode_rows, format_table, method_report)
from marl_mrta.mappo.policy import PolicyFileError, load_policy
from marl_mrta.model.goal_timeout import check_goal_timeout, describe_timeout
from marl_mrta.model.scenario import Scenario, ScenarioError

METHODS = ("random", "ga", "exact", "auction", "policy", "lookahead", "rollout", "replan")
#: The methods that act with an actor file (--policy).
POLICY_METHODS = ("policy", "lookahead", "rollout")
#: "ros": episodes run in the ROS graph through rl_task_allocation_manager's services.
CLI_EXECUTORS = EXECUTORS + ("ros",)
DEFAULT_SCENARIO = package_root() / "scenarios" / "lab_2r.xml"


class UsageError(ValueError):
    """Bad command-line input; one line."""


def parse_args(argv: Optional[Sequence[str]] = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="evaluate", description=__doc__.split("\n\n")[0])
    parser.add_argument("--method", required=True,
                        help=f"one or more of {', '.join(METHODS)}, comma-separated")
    parser.add_argument("--scenario", default=None,
                        help="scenario XML file (default: scenarios/lab_2r.xml; with --executor ros the manager's)")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per method (default 20)")
    parser.add_argument("--executor", default="embedded", choices=CLI_EXECUTORS,
                        help="embedded, or ros: through a running rl_task_allocation_manager (default embedded)")
    parser.add_argument("--manager", default="/rl_task_allocation_manager",
                        help="--executor ros: the task manager node (default /rl_task_allocation_manager)")
    parser.add_argument("--profile", default=None,
                        help="embedded noise profile of config/task_embedded.yaml (default: its `profile`)")
    parser.add_argument("--decision-mode", default=None, metavar="MODE",
                        help="synchronous (the paper's steps) or event (a robot decides when it comes free) "
                             "(default: config/task.yaml; --executor ros: the task manager's)")
    parser.add_argument("--goal-timeout", default=None, metavar="auto|S",
                        help="s a goal may take before it fails, or auto (each leg its own, from its nominal travel "
                             "time: config/task.yaml's goal_timeout_factor and goal_timeout_margin) (default: the "
                             "scenario's <episode goal_timeout>, else config/task.yaml's; --executor ros: the task "
                             "manager's)")
    parser.add_argument("--no-both-references", dest="both_references", action="store_false",
                        help="do not also plan the other decision mode's reference (by default the two are "
                             "printed side by side and kept in the result file)")
    parser.add_argument("--mask", default=None, choices=MASK_MODES, help="action masks (default: for --method policy the mask the actor was trained with, "
                        "else config/task.yaml)")
    parser.add_argument("--hold-successors", action="store_true",
                        help="a robot early at a successor waits for its predecessors, and the plans are made for "
                             "it (docs/guide/evaluation.md, Step rules; default: config/task.yaml, or on with an actor "
                             "--policy trained under it; --executor ros: the task manager's)")
    parser.add_argument("--policy", default=None,
                        help="actor file for --method policy, lookahead or rollout (an MLP actor: its scenario; a set actor: any "
                             "scenario), or generalist (the shipped set actor)")
    parser.add_argument("--seed", type=int, default=0, help="seed of episodes and planners (default 0)")
    parser.add_argument("--out", default=None,
                        help="JSON output file, or a directory for the default name "
                             "(default results/runs/evaluate_<scenario>_<methods>.json)")
    parser.add_argument("--no-exact", action="store_true", help="skip the exact reference (no ratio column)")
    parser.add_argument("--time-limit", type=float, default=None,
                        help="s of CP-SAT deterministic time per model of the reference (default: config/task_baselines.yaml)")
    parser.add_argument("--workers", type=int, default=None,
                        help="CP-SAT search workers (default: config/task_baselines.yaml; more than one may return "
                             "another plan of the same optimum)")
    parser.add_argument("--precedence-margin", type=float, default=None,
                        help="s every plan, and every episode the lookahead keeps, leaves between a predecessor's "
                             "finish and its successor's arrival in one step (default: config/task_baselines.yaml)")
    parser.add_argument("--quiet", action="store_true", help="no progress line")
    # roslaunch appends remappings (__name:=..., __log:=...) to a node's command line.
    args = parser.parse_args([a for a in (sys.argv[1:] if argv is None else argv) if ":=" not in a])
    methods = [m.strip() for m in args.method.split(",") if m.strip()]
    unknown = [m for m in methods if m not in METHODS]
    if not methods or unknown:
        raise UsageError(f"--method: {', '.join(unknown) or 'nothing given'}: choose from {', '.join(METHODS)}")
    if args.episodes < 1:
        raise UsageError(f"--episodes: must be at least 1, got {args.episodes}")
    if args.decision_mode is not None and args.decision_mode not in DECISION_MODES:
        raise UsageError(f"--decision-mode: {args.decision_mode!r} is not one of {', '.join(DECISION_MODES)}")
    try:
        args.goal_timeout = check_goal_timeout(args.goal_timeout, "--goal-timeout")
    except ConfigError as error:
        raise UsageError(str(error)) from None
    needs_actor = [m for m in methods if m in POLICY_METHODS]
    if needs_actor and not args.policy:
        raise UsageError(f"--policy: the {needs_actor[0]} method needs an actor file (--policy path/to/actor.pt)")
    if args.time_limit is not None and not args.time_limit > 0:
        raise UsageError(f"--time-limit: must be positive, got {args.time_limit:g}")
    if args.precedence_margin is not None and not (math.isfinite(args.precedence_margin)
                                                   and args.precedence_margin >= 0.0):
        raise UsageError(f"--precedence-margin: must be a finite number of seconds >= 0, got {args.precedence_margin:g}")
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers: must be at least 1, got {args.workers}")
    if "replan" in methods and args.executor == "ros":
        raise UsageError("--method replan: runs in process here; in the ROS graph the task manager runs it "
                         "(allocator:=replan, docs/guide/live_fleet.md)")
    if args.executor == "ros" and args.profile:
        raise UsageError("--profile: noise profiles belong to the embedded executor (the simulator has its own)")
    args.methods = methods
    return args


def make_ros_env(args: argparse.Namespace):
    """The ROS executor: a client of the running task manager, checked against --scenario and --mask."""
    from marl_mrta.ros.env_client import RosTaskEnvClient
    env = RosTaskEnvClient(args.manager)
    if args.scenario and Path(args.scenario).resolve() != env.scenario_path:
        raise UsageError(f"--scenario: {args.scenario} differs from the scenario the task manager runs "
                         f"({env.scenario_path})")
    if args.mask and args.mask != env.settings.mask:
        raise UsageError(f"--mask: {args.mask} differs from the task manager's mask ({env.settings.mask})")
    if args.hold_successors and not env.settings.hold_successors:
        raise UsageError("--hold-successors: the task manager runs without it (its hold_successors parameter)")
    if args.decision_mode and args.decision_mode != env.settings.decision_mode:
        raise UsageError(f"--decision-mode: {args.decision_mode} differs from the task manager's "
                         f"({env.settings.decision_mode})")
    if args.goal_timeout is not None and args.goal_timeout != env.settings.goal_timeout.value:
        raise UsageError(f"--goal-timeout: {describe_timeout(args.goal_timeout)} differs from the task manager's "
                         f"({describe_timeout(env.settings.goal_timeout.value)}; start it with goal_timeout:=...)")
    if {"policy", "lookahead"} & set(args.methods):
        LearnedPolicy.trained_mask(args.policy, env.settings.mask)
    return env


def plan_for(method: str, instance: SchedulingInstance, settings, seed: int) -> Plan:
    if method == "ga":
        return under_either_rules(lambda inst: solve_ga(inst, settings.ga, seed=seed), instance)
    if method == "auction":
        return under_either_rules(lambda inst: solve_auction(inst, settings.auction_objective), instance)
    raise ValueError(method)


def lookahead_for(args: argparse.Namespace, env, settings, margin: float) -> Lookahead:
    """The lookahead of the robots' own actors (evaluation/lookahead.py) on the environment's
    scenario, its episodes keeping the precedence margin of the plans."""
    actor = LearnedPolicy.from_file(args.policy, env.n_agents, env.obs_dim, env.n_actions, seed=args.seed,
                                    scenario=env.scenario).actor
    try:
        return Lookahead(actor, settings.lookahead, env.settings.hold_successors, margin, env.settings.decision_mode)
    except ValueError as error:
        raise PolicyLoadError(f"--method lookahead: {error}") from None


def rollout_for(args: argparse.Namespace, scenario: Scenario, instance: SchedulingInstance, settings) -> Plan:
    """The actor's rollout plan, made on an embedded, ideal environment of the scenario under the
    actor's own mask (whatever executor runs the episodes)."""
    try:
        actor = load_policy(args.policy, seed=args.seed, scenario=scenario)
    except (PolicyFileError, ScenarioError) as error:
        raise PolicyLoadError(str(error)) from None
    try:
        plan = rollout_plan(actor, scenario, instance, settings.rollout, actor.action_mask, args.seed)
    except RolloutError as error:
        raise PolicyLoadError(f"--method rollout: {error}") from None
    details = plan.details
    alone = details["greedy_makespan"]
    alone_note = f"{alone:.2f} s" if alone is not None else "not complete in order" + (
        f" with the margin of {instance.precedence_margin:g} s" if instance.precedence_margin else "")
    tried = details["orientation_makespans"]
    turned = "" if len(tried) == 1 else (
        f", the floor's orientation {details['orientation']} ({len(tried)} of {settings.rollout.orientations} tried "
        f"within the budget; as it is: " + (f"{tried[0]:.2f} s" if tried[0] is not None else "no plan") + ")")
    print(f"  rollout: {details['play_outs']} episodes played out, {plan.makespan:.2f} s{turned} (the actor alone "
          f"{alone_note})" + ("; budget reached, the actor decided the rest" if details["budget_reached"] else ""),
          file=sys.stderr)
    return plan


def ratio_note(reference: Reference) -> str:
    """Which makespan the ratios divide by."""
    margin = reference.plan.instance.precedence_margin if reference.plan.instance else 0.0
    under = f" of plans with a precedence margin of {margin:g} s" if margin > 0 else ""
    if reference.proven_optimal:
        return f"ratios: makespan / the proven optimum{under} {reference.best_makespan:.2f} s"
    return (f"ratios: makespan / the best known{under} {reference.best_makespan:.2f} s ({reference.best_source}; not "
            f"proven optimal: lower bound {reference.lower_bound:.2f} s, {reference.gap_text()})")


def plan_json(plan: Plan, task_ids: Sequence[str]) -> Dict[str, Any]:
    thinnest = simulate_joint_actions(plan.instance, plan.joint_actions).thinnest_margin if plan.instance else math.inf
    return {"method": plan.method, "makespan": plan.makespan, "logic_violations": plan.logic_violations,
            "proven_optimal": plan.proven_optimal, "robot_tasks": plan.describe(task_ids),
            # s a leg may run late before the plan loses its order (null: no step finishes a task and its successor)
            "thinnest_precedence_margin": thinnest if math.isfinite(thinnest) else None,
            "precedence_margin": plan.instance.precedence_margin if plan.instance else 0.0,
            "joint_actions": [[None if a is None else task_ids[a] for a in step] for step in plan.joint_actions],
            "details": plan.details}


def output_path(args: argparse.Namespace, scenario_name: str) -> Path:
    """--out as a file, or a directory that receives the default name; checked (and its
    directory made) before any episode runs, so a bad path costs nothing."""
    executor = "" if args.executor == "embedded" else f"{args.executor}_"
    name = f"evaluate_{executor}{scenario_name}_{'_'.join(args.methods)}.json"
    if not args.out:
        out = runs_dir() / name
    else:
        out = Path(args.out)
        if out.is_dir() or args.out.endswith(("/", os.sep)):
            out = out / name
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise UsageError(f"--out {args.out}: cannot make the directory {out.parent}: {error.strerror}") from None
    if not os.access(out.parent, os.W_OK) or (out.exists() and not os.access(out, os.W_OK)):
        raise UsageError(f"--out {args.out}: {out} is not writable")
    return out


def evaluate(args: argparse.Namespace) -> int:
    if set(args.methods) & set(POLICY_METHODS):
        import torch
        torch.set_num_threads(1)   # small networks, many calls (a rollout's or a lookahead's play-outs): one thread is faster
    if args.executor == "ros":
        env = make_ros_env(args)
    else:
        if {"policy", "lookahead"} & set(args.methods):
            args.mask = LearnedPolicy.trained_mask(args.policy, args.mask)
        if args.policy and not args.hold_successors and LearnedPolicy.trained_hold(args.policy):
            # Its episodes and plans under the rules it learned: a robot may be sent ahead to wait.
            print(f"evaluate: {args.policy} was trained under hold_successors: the episodes hold", file=sys.stderr)
            args.hold_successors = True
        env = make_env(args.scenario or DEFAULT_SCENARIO, args.executor, profile=args.profile, mask=args.mask,
                       seed=args.seed, hold_successors=True if args.hold_successors else None,
                       decision_mode=args.decision_mode, goal_timeout=args.goal_timeout)
    scenario = env.scenario
    if "replan" in args.methods and env.settings.decision_mode != "event":
        raise UsageError("--method replan: the replanning allocator decides on events; add --decision-mode event")
    out = output_path(args, scenario.name)
    settings = load_baseline_settings().with_cpsat(args.time_limit, args.workers)
    margin = settings.precedence_margin if args.precedence_margin is None else args.precedence_margin
    # Plans for the rules the episodes run under: with the hold, robots may be sent ahead to wait.
    mode = env.settings.decision_mode
    instance = scheduling_instance(scenario, env.settings.min_step, env.settings.goal_timeout, margin,
                                   env.settings.hold_successors, mode)
    task_ids = [t.id for t in scenario.tasks]
    plans: Dict[str, Plan] = {m: plan_for(m, instance, settings, args.seed) for m in args.methods if m in ("ga", "auction")}
    if "rollout" in args.methods:
        plans["rollout"] = rollout_for(args, scenario, instance, settings)

    reference: Optional[Reference] = None
    references: Dict[str, Reference] = {}
    if not args.no_exact or "exact" in args.methods:
        if not args.quiet:   # its search can take minutes on a large team, before any robot moves
            print(f"evaluate: planning the reference of {scenario.name} ({scenario.n_robots} robots, "
                  f"{scenario.n_tasks} tasks; config/task_baselines.yaml's budget)", file=sys.stderr)
        reference = solve_reference(instance, settings, candidates=list(plans.values()))
        for line in reference.log:
            print(f"  {line}", file=sys.stderr)
        print(reference.describe(), file=sys.stderr)
        plans["exact"] = reference.plan
        references = {mode: reference}
        if args.both_references:
            other = "synchronous" if mode == "event" else "event"
            references[other] = solve_reference(dataclasses.replace(instance, decision_mode=other), settings)
            for name in DECISION_MODES:
                print(f"  {name:<11} {references[name].describe()}", file=sys.stderr)
    best = reference.best_makespan if reference is not None else None
    lower = reference.lower_bound if reference is not None else None
    basis = reference.ratio_basis if reference is not None else "exact"

    summaries, results = [], []
    stop_on_abort = getattr(env, "stops_on_abort", False)   # real robots: a safety stop ends the run
    aborted = ""
    for method in args.methods:
        if aborted:
            break
        plan = plans.get(method)
        if method == "random":
            policy = RandomPolicy(env.n_agents, env.n_tasks, settings.random_choice, seed=args.seed)
        elif method == "policy":
            policy = LearnedPolicy.from_file(args.policy, env.n_agents, env.obs_dim, env.n_actions, seed=args.seed,
                                             scenario=scenario)
        elif method == "lookahead":
            lookahead = lookahead_for(args, env, settings, margin)
            policy = in_process_team(lookahead.policy, lookahead)
        elif method == "replan":
            policy = ReplanPolicy(env, settings.replan)
        else:
            policy = plan_policy(plan, env.n_agents, env.n_tasks, mode)
        progress = None if args.quiet else ProgressLine(f"{method} on {scenario.name}")
        started = time.monotonic()
        records = run_episodes(env, policy, args.episodes, args.seed, progress, stop_on_abort=stop_on_abort)
        if stop_on_abort and records[-1].abort_reason:
            aborted = f"{method} episode {len(records) - 1} aborted: {records[-1].abort_reason}"
        seconds = time.monotonic() - started
        if method == "lookahead":
            decisions = max(1, sum(r.decision_steps for r in records) * env.n_agents)
            opening = lookahead.opening
            opened = "" if lookahead.budget.opening is None else (
                "; no rollout plan to open with" if opening is None else
                f"; opened with the rollout plan, {opening.usable_makespan:.2f} s, made in {lookahead.opening_s:.1f} s")
            print(f"  lookahead: {lookahead.searches} steps searched, {lookahead.play_outs} episodes "
                  f"played out, {seconds / decisions:.2f} s per robot decision{opened}", file=sys.stderr)
        summary, report = method_report(method, records, [t.category for t in scenario.tasks],
                                        out.with_name(f"{out.stem}_{method}_gantt.png"),
                                        f"{method} · {scenario.name}", best, lower, basis)
        summaries.append(summary)
        results.append({
            "summary": report["summary"], "seconds": seconds, "gantt": report["gantt"],
            "plan": plan_json(plan, task_ids) if plan is not None else None,
            "representative_episode": report["representative_episode"], "episodes": episode_rows(records),
        })
    print(format_table(summaries))
    if reference is not None:
        print(ratio_note(reference))
    document = {
        "scenario": str(scenario.source), "scenario_name": scenario.name, "executor": args.executor,
        "mode": getattr(env, "mode", "simulation"),
        # ros: the simulator's noise profile, which the episodes ran under
        "profile": env.noise_profile if args.executor == "ros" else args.profile or "default",
        "mask": env.settings.mask, "hold_successors": env.settings.hold_successors,
        "goal_timeout": env.settings.goal_timeout.value, "episode_timeout": scenario.episode_timeout,
        "episodes": args.episodes,
        **({"decision_mode": mode} if mode != "synchronous" else {}),
        "seed": args.seed,
        "exact": plan_json(reference.plan, task_ids) if reference is not None else None,
        "reference": reference.as_dict() if reference is not None else None,
        **({"references": {name: ref.as_dict() for name, ref in references.items()}} if len(references) > 1 else {}),
        "results": results,
    }
    write_result(out, document)
    print(f"wrote {out} and {len(results)} Gantt chart(s)", file=sys.stderr)
    if aborted:
        print(f"evaluate: {aborted}; no further episode started", file=sys.stderr)
        return 1
    return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    lost: tuple = ()
    try:
        args = parse_args(argv)
        if args.executor == "ros":
            from marl_mrta.ros.env_client import ManagerUnavailable
            lost = (ManagerUnavailable,)
        return evaluate(args)
    except (UsageError, ScenarioError, ConfigError, PolicyLoadError) as error:
        print(f"evaluate: {error}", file=sys.stderr)
        return 2
    except lost as error:   # the ROS graph went away mid-run
        print(f"evaluate: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:   # Ctrl-C (real robots: the task manager stops them and writes the episode)
        print("evaluate: interrupted", file=sys.stderr)
        return 130
