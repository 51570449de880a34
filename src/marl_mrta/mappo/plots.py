"""PNG versions of the paper's training figures, drawn from a run's history.

reward_per_robot.png   mean episode reward per robot over episodes (paper Figures 9, 10, 12)
reward_components.png  logic / navigation time / idle / collision parts (Figure 9's breakdown)
losses.png             total, policy and value loss over updates (Figure 11 a–c)
collisions.png         collision events per episode (Figure 14)
makespan.png           episode makespan and the greedy policy's, against the target
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, List, Optional

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
import numpy as np  # noqa: E402

COMPONENT_TITLES = {"logic": "logic", "nav": "navigation time", "idle": "idle", "collision": "collision"}


def moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing mean over up to `window` values (same length as the input)."""
    values = np.asarray(values, dtype=float)
    cumulative = np.concatenate([[0.0], np.cumsum(values)])
    ends = np.arange(1, len(values) + 1)
    starts = np.maximum(ends - window, 0)
    return (cumulative[ends] - cumulative[starts]) / (ends - starts)


def _window(n: int) -> int:
    return max(1, n // 50)


def write_plots(history: Dict[str, List[Dict[str, Any]]], out_dir: Path, n_agents: int,
                target_makespan: Optional[float] = None) -> List[Path]:
    """Draw every figure that has data; returns the files written."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    episodes, updates = history["episodes"], history["updates"]
    written = []
    if episodes:
        index = np.arange(1, len(episodes) + 1)
        window = _window(len(episodes))

        fig, ax = plt.subplots(figsize=(7, 4))
        rewards = np.array([e["reward_per_robot"] for e in episodes])
        for robot in range(rewards.shape[1]):
            ax.plot(index, moving_average(rewards[:, robot], window), label=f"robot {robot}")
        ax.set(xlabel="episode", ylabel=f"episode reward (mean of {window})", title="Mean reward per robot")
        ax.legend()
        written.append(_save(fig, out_dir / "reward_per_robot.png"))

        names = [n for n in COMPONENT_TITLES if n in episodes[0]["components"]]
        fig, axes = plt.subplots(len(names), 1, figsize=(7, 2.2 * len(names)), sharex=True, squeeze=False)
        for ax, name in zip(axes[:, 0], names):
            values = np.array([np.mean(e["components"][name]) for e in episodes])
            ax.plot(index, moving_average(values, window))
            ax.set(ylabel=COMPONENT_TITLES[name])
        axes[0, 0].set_title("Reward components (unweighted, mean over robots)")
        axes[-1, 0].set_xlabel("episode")
        written.append(_save(fig, out_dir / "reward_components.png"))

        fig, ax = plt.subplots(figsize=(7, 3.5))
        collisions = np.array([e["collisions"] for e in episodes])
        ax.plot(index, collisions, ".", markersize=2, alpha=0.3, label="episode")
        ax.plot(index, moving_average(collisions, window), label=f"mean of {window}")
        ax.set(xlabel="episode", ylabel="collision events", title="Collision events per episode")
        ax.legend()
        written.append(_save(fig, out_dir / "collisions.png"))

        fig, ax = plt.subplots(figsize=(7, 3.5))
        finished = np.array([e["makespan"] if e["terminated"] else np.nan for e in episodes])
        ok = np.isfinite(finished)
        if ok.any():
            ax.plot(index[ok], moving_average(finished[ok], window), label="training episodes (completed)")
        evaluations = history.get("evaluations", [])
        if evaluations:
            xs = [_episodes_at(updates, e["update"]) for e in evaluations]
            greedy = [e["makespan"] if np.isfinite(e["makespan"]) else np.nan for e in evaluations]
            ax.plot(xs, greedy, "o-", label="greedy policy (gaps: did not finish)")
        if target_makespan is not None:
            ax.axhline(target_makespan, color="k", linestyle="--", label="target")
        ax.set(xlabel="episode", ylabel="makespan (s)", title="Episode makespan")
        ax.legend()
        written.append(_save(fig, out_dir / "makespan.png"))
    if updates:
        number = [u["update"] for u in updates]
        fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
        for ax, key, title in zip(axes, ("loss", "policy_loss", "value_loss"), ("total loss", "policy loss", "value loss")):
            ax.plot(number, [u[key] for u in updates])
            ax.set(ylabel=title)
        axes[0].set_title("Training losses")
        axes[-1].set_xlabel("update")
        written.append(_save(fig, out_dir / "losses.png"))
    return written


def _episodes_at(updates: List[Dict[str, Any]], update: int) -> int:
    for record in updates:
        if record["update"] == update:
            return int(record["episodes"])
    return 0


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
