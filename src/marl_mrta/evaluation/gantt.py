"""Gantt chart of one episode's schedule (the paper's Figures 15–16), written as PNG."""
from __future__ import annotations

from pathlib import Path
from typing import Union

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
from matplotlib.patches import Patch  # noqa: E402

from marl_mrta.model.schedule import EpisodeRecord  # noqa: E402

_CATEGORY_COLOURS = ("#4c72b0", "#dd8452", "#55a868", "#8172b3", "#937860", "#da8bc3")


def plot_gantt(record: EpisodeRecord, categories_by_task, path: Union[str, Path], title: str = "") -> Path:
    """One row per robot: navigation bars coloured by task category (hatched when the trip
    finished nothing), service time darker (with hold_successors, the wait before it too), idle time
    grey, wrong-order finishes outlined red, dashed lines at step ends (event mode: none; a robot is
    idle between one attempt's end and its next decision)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    categories = sorted(set(categories_by_task))
    colour = {c: _CATEGORY_COLOURS[i % len(_CATEGORY_COLOURS)] for i, c in enumerate(categories)}
    n_robots = len(record.robot_ids)
    fig, ax = plt.subplots(figsize=(10, 1.0 + 0.7 * n_robots))
    step_ends = []
    t = 0.0
    for duration in record.step_durations:
        t += duration
        step_ends.append(t)
    step_start = [0.0] + step_ends[:-1]
    busy_until = {}
    for entry in record.entries:
        y = n_robots - 1 - entry.robot
        category = categories_by_task[entry.task]
        ax.broken_barh([(entry.start, max(entry.end - entry.start, 1e-3))], (y - 0.35, 0.7),
                       facecolors=colour[category], alpha=1.0 if entry.finished else 0.35,
                       hatch=None if entry.finished else "//",
                       edgecolor="red" if entry.finished and not entry.logic_correct else "black", linewidth=0.8)
        label = record.task_ids[entry.task] + ("" if entry.finished else " ×")
        ax.text(entry.start + (entry.end - entry.start) / 2, y, label, ha="center", va="center", fontsize=8)
        end = entry.end
        if entry.finished and entry.service_end is not None and entry.service_end > entry.end:
            ax.broken_barh([(entry.end, entry.service_end - entry.end)], (y - 0.35, 0.7), facecolors="#333333")
            end = entry.service_end
        busy_until[(entry.robot, entry.step)] = end
    if record.decision_mode == "event":
        # No steps: a robot is idle from the end of one attempt to the start of its next.
        for robot in range(n_robots):
            mine = sorted((e for e in record.entries if e.robot == robot), key=lambda e: e.start)
            free = 0.0
            for entry in mine + [None]:
                start = record.makespan if entry is None else entry.start
                if start - free > 1e-6:
                    ax.broken_barh([(free, start - free)], (n_robots - 1 - robot - 0.15, 0.3), facecolors="#cccccc")
                if entry is not None:
                    free = busy_until.get((robot, entry.step), entry.end)
    else:
        for step, (start, end) in enumerate(zip(step_start, step_ends)):
            for robot in range(n_robots):
                idle_from = busy_until.get((robot, step), start)
                if end - idle_from > 1e-6:
                    ax.broken_barh([(idle_from, end - idle_from)], (n_robots - 1 - robot - 0.15, 0.3),
                                   facecolors="#cccccc")
            ax.axvline(end, color="grey", linestyle="--", linewidth=0.6)
    ax.set_yticks(range(n_robots))
    ax.set_yticklabels([f"R{i} ({rid})" for i, rid in enumerate(record.robot_ids)][::-1])
    ax.set_xlabel("episode time (s)")
    ax.set_xlim(0, max(record.makespan, 1e-3) * 1.02)
    state = "logic-consistent" if record.logic_consistent else ("complete, order violated" if record.complete
                                                                 else "incomplete")
    summary = f"makespan {record.makespan:.1f} s, {record.decision_steps} steps, {state}"
    ax.set_title(f"{title} · {summary}" if title else summary)
    handles = [Patch(facecolor=colour[c], label=f"category {c}") for c in categories]
    handles += [Patch(facecolor="#333333", label="service (and waiting for predecessors)"),
                Patch(facecolor="#cccccc", label="idle"), Patch(facecolor="white", hatch="//", edgecolor="black",
                                                                 label="trip finishing nothing"),
                Patch(facecolor="white", edgecolor="red", label="wrong order")]
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.25), ncol=len(handles), fontsize=8,
              frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
