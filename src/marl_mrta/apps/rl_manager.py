"""rl_manager: decentralised execution (`execute`) and MAPPO training (`train`) as ROS nodes.

`execute` is an orchestrator, not a policy: it resets the task manager, sends each robot only
its own observation row on /<robot>/task_observation, collects every robot's
/<robot>/task_choice for that step, and steps the manager with the joint action. The episodes
run through the one episode loop (the same statistics and table as `evaluate`).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Callable, Dict, Optional, Sequence, Tuple

import rospy

from marl_mrta.baselines.reference import Reference, scheduling_instance, solve_reference
from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import runs_dir
from marl_mrta.common.results import write_result
from marl_mrta.evaluation.decentralised import ActorTimeout, ChoiceBoard, DecentralisedPolicy
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.evaluation.summary import (MethodSummary, ProgressLine, episode_rows, format_table, method_report)
from marl_mrta.mappo.claims import ClaimRules
from marl_mrta.mappo.set_view import SetView
from marl_mrta.model.scenario import ScenarioError
from marl_mrta.ros.actor_links import RosActorLinks, check_actor_masks
from marl_mrta.ros.env_client import ManagerUnavailable, RosTaskEnvClient


def parse_execute_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="rl_manager execute",
                                     description="Run episodes decided by the robots' own robot_actor nodes.")
    parser.add_argument("--episodes", type=int, default=20, help="episodes (default 20)")
    parser.add_argument("--seed", type=int, default=0, help="episode k is reset with seed + k (default 0)")
    parser.add_argument("--manager", default="/rl_task_allocation_manager", help="the task manager node")
    parser.add_argument("--choice-timeout", type=float, default=30.0,
                        help="wall s to wait for every robot's task_choice of a step (default 30)")
    parser.add_argument("--connect-timeout", type=float, default=120.0,
                        help="wall s to wait for the robots' actors at start (default 120)")
    parser.add_argument("--out", default=None,
                        help="JSON output file (default results/runs/execute_ros_<scenario>.json, Gantt chart beside it)")
    parser.add_argument("--no-exact", action="store_true", help="skip the exact reference (no ratio column)")
    args = parser.parse_args(list(argv))
    if args.episodes < 1:
        raise ValueError(f"--episodes: must be at least 1, got {args.episodes}")
    for name in ("choice_timeout", "connect_timeout"):
        if not getattr(args, name) > 0:
            raise ValueError(f"--{name.replace('_', '-')}: must be positive, got {getattr(args, name)}")
    return args


def execute(args: argparse.Namespace, log: Callable[[str], None]) -> Dict:
    """Run args.episodes decentralised episodes, print the evaluation table, write the JSON."""
    env = RosTaskEnvClient(args.manager)
    prefix = rospy.get_param(env.manager + "/robot_prefix", "")
    namespaces = [prefix + robot.id for robot in env.scenario.robots]
    board = ChoiceBoard(namespaces)
    links = RosActorLinks(namespaces, board)
    log(f"rl_manager: waiting for the actors of {', '.join(namespaces)}")
    links.wait_connected(args.connect_timeout)
    decision_order, turn_order = check_actor_masks(namespaces, env.settings.mask)
    claim_rules = ClaimRules(decision_order, env.scenario.predecessors)
    if claim_rules.sequential:
        log(f"rl_manager: decision order {decision_order}, turns by {turn_order}: robots answer in turn, each told "
            f"the tasks claimed before it")
    # The order the robots' set actors read from their own rows (None: index order).
    turns = SetView(env.scenario, turn_order).turns if claim_rules.sequential and turn_order != "index" else None

    policy = DecentralisedPolicy(env.n_agents, links.send, board, args.choice_timeout, stop=rospy.is_shutdown,
                                 claim_rules=claim_rules, turns=turns)
    started = time.monotonic()
    records = run_episodes(env, policy, args.episodes, args.seed, ProgressLine(f"decentralised on {env.scenario.name}"),
                           stop_on_abort=env.stops_on_abort)
    seconds = time.monotonic() - started

    out = Path(args.out) if args.out else runs_dir() / f"execute_ros_{env.scenario.name}.json"

    def report(reference: Optional[Reference]) -> Tuple[MethodSummary, Dict]:
        # As evaluate: the ratio to a proven optimum, else to the best known plan, named as such.
        best, lower, basis = ((reference.best_makespan, reference.lower_bound, reference.ratio_basis)
                              if reference is not None else (None, None, "exact"))
        summary, part = method_report(policy.name, records, [t.category for t in env.scenario.tasks],
                                      out.with_name(f"{out.stem}_gantt.png"), f"decentralised · {env.scenario.name}",
                                      best, lower, basis)
        document = {
            "scenario": str(env.scenario.source), "scenario_name": env.scenario.name, "executor": "ros",
            "execution": "decentralised", "mode": env.mode, "profile": env.noise_profile, "robots": namespaces,
            "mask": env.settings.mask, "goal_timeout": env.settings.goal_timeout.value, "episodes": args.episodes,
            "seed": args.seed,
            "exact_makespan": best if reference is not None and reference.proven_optimal else None,
            "reference": reference.as_dict() if reference is not None else None,
            "seconds": seconds, **part, "records": episode_rows(records),
        }
        write_result(out, document)
        return summary, document

    # The episodes are written before the reference is planned: its search takes up to the
    # reference's budget (minutes on a large team), which neither the robots nor the results wait for.
    summary, document = report(None)
    log(f"rl_manager: {len(records)} episode(s) in {seconds:.1f} s wall; wrote {out} and {document['gantt']}")
    if not args.no_exact:
        log("rl_manager: planning the exact reference for the ratio column (config/task_baselines.yaml's budget; "
            "--no-exact skips it)")
        instance = scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout,
                                       hold_successors=env.settings.hold_successors)
        reference = solve_reference(instance)
        summary, document = report(reference)
        log(f"rl_manager: {reference.describe()}; {out} updated")
    print(format_table([summary]))
    if env.stops_on_abort and records[-1].abort_reason:
        log(f"rl_manager: episode {len(records) - 1} aborted: {records[-1].abort_reason}; no further episode started")
    return document


def train(argv: Sequence[str]) -> int:
    """rl_manager train: the MAPPO trainer (apps/train.py) as a node, logging to rosconsole. Its
    own SIGINT/SIGTERM handling ends a run with a checkpoint, so rospy's is off."""
    from marl_mrta.apps.train import main as train_main
    rospy.init_node("rl_manager", disable_signals=True)
    try:
        return train_main(list(argv), log=rospy.loginfo)
    finally:
        rospy.signal_shutdown("training ended")


def main(argv: Optional[Sequence[str]] = None) -> int:
    """rl_manager MODE [options]; modes `execute` (decentralised episodes) and `train` (MAPPO)."""
    argv = [a for a in (sys.argv[1:] if argv is None else argv) if ":=" not in a]   # roslaunch remappings
    if argv and argv[0] == "train":
        return train(argv[1:])
    if not argv or argv[0] != "execute":
        print("rl_manager: mode: give `execute` (rl_manager execute --episodes N ...) or `train` "
              "(rl_manager train --backend ros --arenas K ...; see train --help)", file=sys.stderr)
        return 2
    try:
        args = parse_execute_args(argv[1:])
    except ValueError as error:
        print(f"rl_manager: {error}", file=sys.stderr)
        return 2
    rospy.init_node("rl_manager")
    try:
        execute(args, rospy.loginfo)
    except (ActorTimeout, ManagerUnavailable) as error:
        rospy.logfatal(f"rl_manager: {error}")
        return 1
    except (ValueError, ScenarioError, ConfigError) as error:
        rospy.logfatal(f"rl_manager: {error}")
        return 2
    return 0
