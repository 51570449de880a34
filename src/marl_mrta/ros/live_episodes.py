"""allocator replan: the task manager runs its episodes itself (docs/guide/live_fleet.md).

The policies of a client (rl_manager, evaluate) see only what ~step returns; the replanning
allocator (baselines/replan.py through evaluation/policies.py's ReplanPolicy, budget in
config/task_baselines.yaml `replan`) reads the environment itself, so it runs in the manager's
process. Episodes run one after another in a thread of their own, through the one episode loop
(evaluation/loop.py's run_episode) over the manager's own reset and step (each under its lock, with
the same topics, status and requests as a client's episodes):
- in simulation the first starts once the graph is up, each after its reset;
- on real robots each after its reset (the drive to the start poses) and the operator's `~go`
  (`go: true`: at once), as every real-mode episode; an aborted episode is the last.
At the end the result document is written (the format of `evaluate` and `rl_manager execute`,
one method `replan`, each episode's whole record beside its figures), and with `end_when_done`
the node shuts down, which ends a launch that requires it.
"""
from __future__ import annotations

import contextlib
import threading
import time
from pathlib import Path
from typing import Any, Dict, List, Sequence, Tuple

import rospy

from marl_mrta.baselines.settings import ReplanSettings
from marl_mrta.common.paths import runs_dir
from marl_mrta.common.results import write_result
from marl_mrta.evaluation.loop import run_episode
from marl_mrta.evaluation.policies import ReplanPolicy
from marl_mrta.evaluation.summary import episode_rows, format_table, method_report, summarize
from marl_mrta.model.schedule import EpisodeRecord
from marl_mrta.ros.manager_settings import LiveFleetSettings
from marl_mrta.ros.sim_clock import SimulatorLost


class _Episodes:
    """The manager's environment as the episode loop drives it (its reset and step)."""

    def __init__(self, node, first_reset_limits):
        self.node = node
        self._first = first_reset_limits

    def reset(self, seed=None):
        limits, self._first = self._first, None
        with (limits() if limits is not None else contextlib.nullcontext()):
            return self.node.reset_episode(seed)

    def step(self, actions):
        return self.node.step_episode(actions)


def result_path(out: str, scenario_name: str) -> Path:
    return Path(out) if out else runs_dir() / f"replan_ros_{scenario_name}.json"


def replan_document(node, records: Sequence[EpisodeRecord], categories: Sequence[Sequence[str]], seconds: float,
                    out: Path, settings: LiveFleetSettings, replan: ReplanSettings) -> Tuple[Dict[str, Any], Any]:
    """The result document of the manager's episodes and its summary; Gantt chart beside it.
    `categories`: per episode, its tasks' categories (submitted tasks included)."""
    env, scenario = node.env, node.env.scenario
    representative = summarize("replan", records, None).representative
    summary, part = method_report("replan", records, categories[representative], out.with_name(f"{out.stem}_gantt.png"),
                                  f"replan · {scenario.name}", None)
    real = node.settings.mode == "real"
    return {
        "scenario": str(scenario.source), "scenario_name": scenario.name, "executor": "ros", "allocator": "replan",
        "mode": node.settings.mode,
        "profile": "real" if real else str(rospy.get_param("/simulator/noise_profile", "unknown")),
        "robots": list(node.executor.namespaces), "mask": env.settings.mask,
        "hold_successors": env.settings.hold_successors, "goal_timeout": env.settings.goal_timeout.value,
        "episode_timeout": scenario.episode_timeout, "decision_mode": "event",
        "on_robot_fault": node.settings.executor.on_robot_fault, "episodes": settings.episodes, "seed": settings.seed,
        "replan": {"method": replan.method, "time_limit": replan.time_limit, "ga_evaluations": replan.ga_evaluations,
                   "delay": replan.delay},
        "results": [{"summary": part["summary"], "seconds": seconds, "gantt": part["gantt"], "plan": None,
                     "representative_episode": part["representative_episode"], "episodes": episode_rows(records),
                     "episode_records": [r.to_dict() for r in records]}],
    }, summary


class ReplanEpisodes:
    """`node`: the TaskManagerNode (its env, executor, settings, reset_episode and step_episode)."""

    def __init__(self, node, settings: LiveFleetSettings, replan: ReplanSettings):
        self.node = node
        self.settings = settings
        self.replan = replan
        self.policy = ReplanPolicy(node.env, replan)

    def start(self) -> None:
        threading.Thread(target=self._run, daemon=True, name="replan_episodes").start()

    def _run(self) -> None:
        node, settings = self.node, self.settings
        real = node.settings.mode == "real"
        episodes = _Episodes(node, None if real else node.executor.start_up_limits)
        records: List[EpisodeRecord] = []
        categories: List[List[str]] = []
        started = time.monotonic()
        for k in range(settings.episodes):
            if rospy.is_shutdown():
                break
            try:
                record = run_episode(episodes, self.policy, settings.seed + k, k)
            except SimulatorLost as lost:   # a reset that failed (real robots: a fault, no go)
                rospy.logerr("allocator replan: episode %d could not start: %s", k, lost)
                break
            records.append(record)
            categories.append([t.category for t in node.env.scenario.tasks])
            rospy.loginfo("allocator replan: episode %d of %d: %s, makespan %.2f s, %d plans", k + 1,
                          settings.episodes, "complete" if record.complete else f"not complete ({record.abort_reason or 'timeout'})",
                          record.makespan, self.policy.plans)
            if real and record.abort_reason:
                rospy.logerr("allocator replan: no further episode after a safety stop")
                break
        if records:
            out = result_path(settings.out, node.env.scenario.name)
            document, summary = replan_document(node, records, categories, time.monotonic() - started, out,
                                                settings, self.replan)
            write_result(out, document)
            print(format_table([summary]))
            rospy.loginfo("allocator replan: %d episode(s); wrote %s and %s", len(records), out, document["results"][0]["gantt"])
        if settings.end_when_done:
            rospy.signal_shutdown("allocator replan: its episodes are done")
