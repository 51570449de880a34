"""Run a decision maker through the environment for N episodes and summarise (paper Tables 8–9)."""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Optional, Sequence

from ..tasks.schedule import EpisodeRecord

ProgressFn = Callable[[int, int], None]


def run_episodes(env, policy, episodes: int, seed: int, progress: Optional[ProgressFn] = None,
                 max_steps: int = 10_000) -> List[EpisodeRecord]:
    """Episode k is reset with seed + k, so runs are reproducible and methods see the same noise draws."""
    records: List[EpisodeRecord] = []
    for k in range(episodes):
        output = env.reset(seed=seed + k)
        policy.begin_episode(output, k)
        for _ in range(max_steps):
            output = env.step(policy.act(output))
            if output.done or output.truncated:
                break
        else:
            raise RuntimeError(f"episode {k} did not end within {max_steps} steps")
        records.append(output.info["episode"])
        if progress is not None:
            progress(k + 1, episodes)
    return records


def _mean_sd(values: Sequence[float]):
    n = len(values)
    mean = sum(values) / n
    sd = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1)) if n > 1 else 0.0
    return mean, sd


@dataclass
class MethodSummary:
    method: str
    scenario: str
    n_robots: int
    episodes: int
    makespan_mean: float
    makespan_sd: float
    complete_pct: float
    tasks_per_robot: List[float]        # mean finished tasks per robot
    decision_steps_mean: float
    decision_steps_sd: float
    logic_consistent_pct: float
    collisions_per_episode: float
    ratio_to_exact: Optional[float]
    representative: int                 # episode index closest to the median makespan
    allocation: List[List[str]]         # task lists of the representative episode

    def as_dict(self) -> Dict[str, Any]:
        return dict(self.__dict__)


def summarize(method: str, records: Sequence[EpisodeRecord], exact_makespan: Optional[float]) -> MethodSummary:
    makespans = [r.makespan for r in records]
    steps = [float(r.decision_steps) for r in records]
    mean, sd = _mean_sd(makespans)
    steps_mean, steps_sd = _mean_sd(steps)
    n_robots = len(records[0].robot_ids)
    per_robot = [sum(r.tasks_per_robot()[i] for r in records) / len(records) for i in range(n_robots)]
    median = sorted(makespans)[len(makespans) // 2]
    representative = min(range(len(records)), key=lambda k: (abs(makespans[k] - median), k))
    rep = records[representative]
    allocation = [[rep.task_ids[t] for t in tasks] for tasks in rep.robot_task_lists()]
    ratio = mean / exact_makespan if exact_makespan and math.isfinite(exact_makespan) else None
    return MethodSummary(
        method=method, scenario=records[0].scenario, n_robots=n_robots, episodes=len(records),
        makespan_mean=mean, makespan_sd=sd,
        complete_pct=100.0 * sum(r.complete for r in records) / len(records),
        tasks_per_robot=per_robot, decision_steps_mean=steps_mean, decision_steps_sd=steps_sd,
        logic_consistent_pct=100.0 * sum(r.logic_consistent for r in records) / len(records),
        collisions_per_episode=sum(sum(r.collisions) for r in records) / len(records),
        ratio_to_exact=ratio, representative=representative, allocation=allocation)


class ProgressLine:
    """One self-overwriting progress line on stderr: episodes done, rate, ETA."""

    def __init__(self, label: str, stream=sys.stderr):
        self.label = label
        self.stream = stream
        self.start = time.monotonic()
        self.last = 0.0

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if done < total and now - self.last < 0.2:
            return
        self.last = now
        rate = done / max(now - self.start, 1e-9)
        eta = (total - done) / rate if rate > 0 else 0.0
        end = "\n" if done == total else ""
        shown = f"{rate:.0f}" if rate >= 10 else f"{rate:.2f}"
        self.stream.write(f"\r{self.label}: episode {done}/{total}  {shown} episodes/s  ETA {eta:.0f} s   {end}")
        self.stream.flush()


def format_table(summaries: Sequence[MethodSummary]) -> str:
    """The paper's Tables 8–9 as text: one row per method, then each method's allocation."""
    header = ("method", "robots", "makespan (s)", "complete", "tasks per robot", "steps/episode",
              "logic-consistent", "collisions/ep", "ratio to exact")
    rows = []
    for s in summaries:
        rows.append((s.method, str(s.n_robots), f"{s.makespan_mean:.2f} ± {s.makespan_sd:.2f}",
                     f"{s.complete_pct:.0f} %", ", ".join(f"{v:.2f}" for v in s.tasks_per_robot),
                     f"{s.decision_steps_mean:.2f} ± {s.decision_steps_sd:.2f}",
                     f"{s.logic_consistent_pct:.0f} %", f"{s.collisions_per_episode:.2f}",
                     "–" if s.ratio_to_exact is None else f"{s.ratio_to_exact:.3f}"))
    widths = [max(len(r[i]) for r in rows + [header]) for i in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in [header] + rows]
    for s in summaries:
        robots = "; ".join(f"R{i} = [{', '.join(tasks)}]" for i, tasks in enumerate(s.allocation))
        lines.append(f"{s.method} allocation (episode {s.representative}): {robots}")
    return "\n".join(lines)
