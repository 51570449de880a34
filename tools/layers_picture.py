"""Draws docs/img/python_layers.png: the Python package's layers (as test/python/test_layers.py
defines them) with the modules of each, bottom to top."""
import sys
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyBboxPatch  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "test" / "python"))
from test_layers import LAYERS  # noqa: E402

ROLE = {
    "common": "settings reader + ConfigError, paths, YAML",
    "model": "maps, scenario, rules, reward, schedule, travel, robot, noise",
    "env": "decision process (Algorithm 1), executors, Policy protocol",
    "baselines": "random, GA, auction, exact / CP-SAT, reference",
    "mappo": "networks, buffer, trainer, runner, actor files",
    "evaluation": "the one episode loop, policies, summaries, decentralised board",
    "ros": "adapters: executor, task manager, env client, arenas, actor links",
    "apps": "command lines and benchmarks (scripts/ are 10-line entry points)",
}


def main() -> None:
    package = ROOT / "src" / "marl_mrta"
    fig, ax = plt.subplots(figsize=(13, 8.5))
    floors = len(LAYERS)
    for floor, names in enumerate(LAYERS):
        width = 10.0 / len(names)
        for k, name in enumerate(names):
            modules = sorted(p.stem for p in (package / name).glob("*.py") if p.stem != "__init__")
            x, y = 0.2 + k * width, floor * 1.0
            ax.add_patch(FancyBboxPatch((x, y + 0.1), width - 0.3, 0.75, boxstyle="round,pad=0.02",
                                        facecolor="#dce6f2" if name not in ("ros", "apps") else "#f2e2dc",
                                        edgecolor="#34495e"))
            # Characters per line that fit the box at these font sizes (the figure is 13 in wide).
            columns = int((width - 0.5) * 15)
            ax.text(x + 0.1, y + 0.72, f"{name}/", fontsize=11, weight="bold", va="center")
            ax.text(x + 0.1, y + 0.53, textwrap.fill(ROLE.get(name, ""), int(columns * 0.8)), fontsize=8,
                    va="center", style="italic")
            ax.text(x + 0.1, y + 0.27, textwrap.fill(", ".join(modules), columns), fontsize=6.5, va="center")
        if floor:
            ax.annotate("", xy=(10.35, floor * 1.0 - 0.1), xytext=(10.35, floor * 1.0 + 0.45),
                        arrowprops=dict(arrowstyle="->", color="#34495e"))
    ax.text(10.5, floors / 2, "imports go down only", rotation=90, va="center", fontsize=9)
    ax.axhline(5.05, color="#c0392b", linestyle="--", linewidth=1)
    ax.text(0.2, 5.0, "ROS above this line only", color="#c0392b", fontsize=8, va="top")
    ax.set_xlim(0, 11)
    ax.set_ylim(0, floors)
    ax.axis("off")
    ax.set_title("marl_mrta: the Python package in layers (test/python/test_layers.py checks every import)", loc="left")
    out = ROOT / "docs" / "img" / "python_layers.png"
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
