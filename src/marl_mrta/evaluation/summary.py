"""What an evaluation reports of a method's episodes: the paper's Tables 8–9, progress, documents."""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

from marl_mrta.model.schedule import EpisodeRecord


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
    ratio_to_exact: Optional[float]     # mean makespan ÷ the reference's best makespan (see ratio_basis)
    representative: int                 # episode index closest to the median makespan
    allocation: List[List[str]]         # task lists of the representative episode
    ratio_basis: str = "exact"          # exact: the reference is a proven optimum | best known: it is not
    ratio_to_lower_bound: Optional[float] = None   # mean makespan ÷ the reference's proven lower bound

    def as_dict(self) -> Dict[str, Any]:
        return dict(self.__dict__)


def _ratio(value: float, reference: Optional[float]) -> Optional[float]:
    return value / reference if reference and math.isfinite(reference) else None


def summarize(method: str, records: Sequence[EpisodeRecord], exact_makespan: Optional[float],
              lower_bound: Optional[float] = None, ratio_basis: str = "exact") -> MethodSummary:
    """exact_makespan: the reference's best makespan (ratio_basis says whether it is proven
    optimal); lower_bound: its proven lower bound."""
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
    return MethodSummary(
        method=method, scenario=records[0].scenario, n_robots=n_robots, episodes=len(records),
        makespan_mean=mean, makespan_sd=sd,
        complete_pct=100.0 * sum(r.complete for r in records) / len(records),
        tasks_per_robot=per_robot, decision_steps_mean=steps_mean, decision_steps_sd=steps_sd,
        logic_consistent_pct=100.0 * sum(r.logic_consistent for r in records) / len(records),
        collisions_per_episode=sum(sum(r.collisions) for r in records) / len(records),
        ratio_to_exact=_ratio(mean, exact_makespan), representative=representative, allocation=allocation,
        ratio_basis=ratio_basis, ratio_to_lower_bound=_ratio(mean, lower_bound))


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
              "logic-consistent", "collisions/ep", f"ratio to {summaries[0].ratio_basis if summaries else 'exact'}")
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


def episode_rows(records: Sequence[EpisodeRecord]) -> List[Dict[str, Any]]:
    """One line of figures per episode, as the result documents list them."""
    return [{"makespan": r.makespan, "decision_steps": r.decision_steps, "complete": r.complete,
             "logic_consistent": r.logic_consistent, "collisions": sum(r.collisions),
             "tasks_per_robot": r.tasks_per_robot()} for r in records]


def method_report(method: str, records: Sequence[EpisodeRecord], categories: Sequence[str], gantt: Path,
                  title: str, exact_makespan: Optional[float], lower_bound: Optional[float] = None,
                  ratio_basis: str = "exact") -> "tuple[MethodSummary, Dict[str, Any]]":
    """A method's summary, the Gantt chart of its representative episode (written to `gantt`) and
    the document part every result file carries: summary, chart path, representative episode."""
    from marl_mrta.evaluation.gantt import plot_gantt   # matplotlib only where a chart is drawn
    summary = summarize(method, records, exact_makespan, lower_bound, ratio_basis)
    plot_gantt(records[summary.representative], list(categories), gantt, title=title)
    return summary, {"summary": summary.as_dict(), "gantt": str(gantt),
                     "representative_episode": records[summary.representative].to_dict()}
