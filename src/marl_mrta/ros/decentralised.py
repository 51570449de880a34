"""Decentralised execution: episodes whose every decision is taken by the robots' own actor nodes.

rl_manager's `execute` mode is an orchestrator, not a policy: it resets the task manager,
sends each robot only its own observation row on /<robot>/task_observation, collects every
robot's /<robot>/task_choice for that step, and steps the manager with the joint action.
The episodes run through evaluation.runner (the same statistics and table as `evaluate`).

This module is the rospy side (RosActorLinks, execute()); the board and the policy it drives
are ROS-free (evaluation/decentralised.py).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Callable, Dict, Optional, Sequence

from ..evaluation.decentralised import (ACTOR_NODE, CHOICE_TOPIC, OBSERVATION_TOPIC, ActorTimeout, ChoiceBoard,
                                        DecentralisedPolicy, ObservationRow)
from ..mappo.claims import ClaimRules


class RosActorLinks:
    """Publishers of /<robot>/task_observation and subscribers of /<robot>/task_choice."""

    def __init__(self, namespaces: Sequence[str], board: ChoiceBoard):
        import rospy
        from marl_mrta.msg import RobotObservation, TaskChoice
        self._rospy = rospy
        self._msg = RobotObservation
        self.namespaces = ["/" + ns.strip("/") for ns in namespaces]
        self.publishers = [rospy.Publisher(ns + "/" + OBSERVATION_TOPIC, RobotObservation, queue_size=10)
                           for ns in self.namespaces]
        self.subscribers = [rospy.Subscriber(ns + "/" + CHOICE_TOPIC, TaskChoice,
                                             lambda m, i=i: board.offer(i, m.episode, m.step, m.action), queue_size=10)
                            for i, ns in enumerate(self.namespaces)]

    def send(self, robot_index: int, row: ObservationRow) -> None:
        self.publishers[robot_index].publish(self._msg(
            episode=row.episode, step=row.step, episode_start=row.episode_start, obs=row.obs.tolist(),
            action_mask=row.action_mask.tobytes(), agent_index=row.agent_index, claimed=row.claimed.tobytes()))

    def wait_connected(self, timeout: float) -> None:
        """Until every robot's actor listens and answers on its topics (both directions)."""
        deadline = time.monotonic() + timeout
        while not self._rospy.is_shutdown():
            missing = [ns for ns, pub, sub in zip(self.namespaces, self.publishers, self.subscribers)
                       if pub.get_num_connections() < 1 or sub.get_num_connections() < 1]
            if not missing:
                return
            if time.monotonic() > deadline:
                raise ActorTimeout(f"{', '.join(missing)}: no {ACTOR_NODE} connected to {OBSERVATION_TOPIC} and "
                                   f"{CHOICE_TOPIC} after {timeout:g} s (launch/execute.launch starts one per robot)")
            time.sleep(0.1)
        raise ActorTimeout("shutdown while waiting for the robots' actors")


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
                        help="JSON output file (default results/execute_ros_<scenario>.json, Gantt chart beside it)")
    parser.add_argument("--no-exact", action="store_true", help="skip the exact reference (no ratio column)")
    args = parser.parse_args(list(argv))
    if args.episodes < 1:
        raise ValueError(f"--episodes: must be at least 1, got {args.episodes}")
    for name in ("choice_timeout", "connect_timeout"):
        if not getattr(args, name) > 0:
            raise ValueError(f"--{name.replace('_', '-')}: must be positive, got {getattr(args, name)}")
    return args


def check_actor_masks(namespaces: Sequence[str], env_mask: str) -> str:
    """Each actor node states the action-mask mode (~action_mask) and decision order
    (~decision_order) its policy was trained with; acting under another mask would feed it
    inputs it never saw. Returns the robots' common decision order."""
    import rospy
    orders = set()
    for ns in namespaces:
        node = "/" + ns.strip("/") + "/" + ACTOR_NODE
        trained = rospy.get_param(node + "/action_mask", None)
        if trained is not None and trained != env_mask:
            raise ValueError(f"{node}/action_mask: the policy was trained with mask "
                             f"{trained}, the task manager runs mask {env_mask} (set mask:={trained})")
        orders.add(rospy.get_param(node + "/decision_order", "simultaneous"))
    if len(orders) > 1:
        raise ValueError(f"{ACTOR_NODE}/decision_order: the robots' policies disagree ({', '.join(sorted(orders))}); "
                         f"give every robot the same policy")
    return orders.pop() if orders else "simultaneous"


def execute(args: argparse.Namespace, log: Callable[[str], None]) -> Dict:
    """Run args.episodes decentralised episodes, print the evaluation table, write the JSON."""
    import rospy
    from ..baselines.plan import SchedulingInstance
    from ..baselines.settings import load_baseline_settings
    from ..env.factory import scenario_travel_table
    from ..evaluation.cli import exact_reference
    from ..evaluation.gantt import plot_gantt
    from ..evaluation.runner import ProgressLine, format_table, run_episodes, summarize
    from ..tasks.config_reader import package_root
    from .env_client import RosTaskEnvClient

    env = RosTaskEnvClient(args.manager)
    prefix = rospy.get_param(env.manager + "/robot_prefix", "")
    namespaces = [prefix + robot.id for robot in env.scenario.robots]
    board = ChoiceBoard(namespaces)
    links = RosActorLinks(namespaces, board)
    log(f"rl_manager: waiting for the actors of {', '.join(namespaces)}")
    links.wait_connected(args.connect_timeout)
    decision_order = check_actor_masks(namespaces, env.settings.mask)
    claim_rules = ClaimRules(decision_order, env.scenario.predecessors)
    if claim_rules.sequential:
        log(f"rl_manager: decision order {decision_order}: robots answer in turn, each told the tasks claimed before it")

    exact_makespan = None
    if not args.no_exact:
        instance = SchedulingInstance.from_scenario(env.scenario, scenario_travel_table(env.scenario),
                                                    env.settings.min_step)
        exact = exact_reference(instance, load_baseline_settings())
        exact_makespan = exact.makespan if exact.proven_optimal else None

    policy = DecentralisedPolicy(env.n_agents, links.send, board, args.choice_timeout, stop=rospy.is_shutdown,
                                 claim_rules=claim_rules)
    started = time.monotonic()
    records = run_episodes(env, policy, args.episodes, args.seed, ProgressLine(f"decentralised on {env.scenario.name}"))
    seconds = time.monotonic() - started
    summary = summarize(policy.name, records, exact_makespan)
    print(format_table([summary]))

    out = Path(args.out) if args.out else package_root() / "results" / f"execute_ros_{env.scenario.name}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    gantt = out.with_name(f"{out.stem}_gantt.png")
    plot_gantt(records[summary.representative], [t.category for t in env.scenario.tasks], gantt,
               title=f"decentralised · {env.scenario.name}")
    document = {
        "scenario": str(env.scenario.source), "scenario_name": env.scenario.name, "executor": "ros",
        "execution": "decentralised", "profile": env.noise_profile, "robots": namespaces, "mask": env.settings.mask,
        "episodes": args.episodes, "seed": args.seed, "exact_makespan": exact_makespan,
        "seconds": seconds, "summary": summary.as_dict(), "gantt": str(gantt),
        "representative_episode": records[summary.representative].to_dict(),
        "records": [{"makespan": r.makespan, "decision_steps": r.decision_steps, "complete": r.complete,
                     "logic_consistent": r.logic_consistent, "collisions": sum(r.collisions),
                     "tasks_per_robot": r.tasks_per_robot()} for r in records],
    }
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(json.dumps(document, indent=1, default=_json_value))
    tmp.replace(out)
    log(f"rl_manager: {args.episodes} episode(s) in {seconds:.1f} s wall; wrote {out} and {gantt}")
    return document


def _json_value(value):
    if hasattr(value, "item"):
        return value.item()
    if isinstance(value, float):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def train(argv: Sequence[str]) -> int:
    """rl_manager train: the MAPPO trainer (mappo/cli.py, ROS-free) as a node, logging to
    rosconsole. Its own SIGINT/SIGTERM handling ends a run with a checkpoint, so rospy's is off."""
    import rospy
    from ..mappo.cli import main as train_main
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
    import rospy
    from ..scenario import ScenarioError
    from ..tasks.config_reader import ConfigError
    from .env_client import ManagerUnavailable
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
