"""The README's "Your own floor" recipe runs as written, on a map the test makes the way map_saver
writes one (trinary PGM and YAML, unknown space around the walls): scenarios drawn on it, the
planners and the generalist compared, the generalist fine-tuned, the trained actor driven in the
ROS simulation, then real.launch. Two lines are the test's: the map_saver line (the test writes the
map instead of a SLAM session) and `stand_in:=true` added to real.launch (no robots here). The
"Real robots" recipe runs in the rostest real_standin (test/nodes/real_standin_test.py)."""
import json
import os
import re
import shlex
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rospkg", reason="ROS not available")
from marl_mrta.model.scenario import load_scenario  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.wallclock]

ROOT = Path(__file__).resolve().parents[2]
FREE, OCCUPIED, UNKNOWN = 254, 0, 205   # map_saver's grey values (trinary, negate 0)
RESOLUTION = 0.05


def recipe(title: str):
    """The command lines of the README's code block after the paragraph that starts with `title`,
    without their comments."""
    readme = (ROOT / "README.md").read_text()
    block = re.search(re.escape(f"**{title}**") + r".*?```bash\n(.*?)```", readme, re.S)
    assert block, f"README.md: no recipe '{title}'"
    lines = []
    for line in block.group(1).splitlines():
        words = shlex.split(line, comments=True)
        if words:
            lines.append(words)
    return lines


def write_map_saver_map(directory: Path, stem: str) -> None:
    """A 7 x 5 m floor in two rooms joined by a 1.2 m door, inside walls, with unknown space
    around them and in a closed store room, as a SLAM session's map_saver leaves it."""
    width, height = int(9.0 / RESOLUTION), int(7.0 / RESOLUTION)
    grid = np.full((height, width), UNKNOWN, np.uint8)
    rows, cols = np.mgrid[0:height, 0:width]
    x, y = cols * RESOLUTION, (height - 1 - rows) * RESOLUTION   # row 0 is the top of the image
    inside = (x >= 1.0) & (x <= 8.0) & (y >= 1.0) & (y <= 6.0)
    grid[inside] = FREE
    wall = (inside & ((x < 1.15) | (x > 7.85) | (y < 1.15) | (y > 5.85)))
    partition = (np.abs(x - 4.5) < 0.08) & ~((y > 3.0) & (y < 4.2))
    store = (x > 6.8) & (y > 4.8)                     # a closed room SLAM never saw into
    grid[wall | (partition & inside)] = OCCUPIED
    grid[store & inside & ~wall] = UNKNOWN
    (directory / f"{stem}.pgm").write_bytes(b"P5\n%d %d\n255\n" % (width, height) + grid.tobytes())
    (directory / f"{stem}.yaml").write_text(
        f"image: {stem}.pgm\nresolution: {RESOLUTION}\norigin: [-1.0, -1.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def test_your_own_floor_recipe_runs_as_written(tmp_path):
    lines = recipe("Your own floor.")
    assert lines[0][:3] == ["rosrun", "map_server", "map_saver"], lines[0]
    write_map_saver_map(tmp_path, lines[0][lines[0].index("-f") + 1])
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{free_port()}", PWD=str(tmp_path),
               ROS_HOME=str(tmp_path / "ros_home"))
    runs = ROOT / "results" / "runs"   # where evaluate and rl_manager write without --out / out:=
    for words in lines[1:]:
        words = [w.replace("$PWD", str(tmp_path)) for w in words]
        real = words[:3] == ["roslaunch", "marl_mrta", "real.launch"]
        if real:
            words = words + ["stand_in:=true"]   # no robots here: the hardware stand-in plays them
        started = time.time()
        done = subprocess.run(words, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
        assert done.returncode == 0, f"{' '.join(words)}:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
        if words[:3] == ["roslaunch", "marl_mrta", "execute.launch"] or real:
            # The trained actor's episodes, in the simulation and through real.launch: complete, in order.
            scenario = load_scenario(next(w for w in words if w.startswith("scenario:="))[len("scenario:="):])
            result = runs / f"execute_ros_{scenario.name}.json"
            assert result.stat().st_mtime >= started, f"{' '.join(words)} wrote no {result}"
            document = json.loads(result.read_text())
            assert document["mode"] == ("real" if real else "simulation")
            assert document["records"] and all(r["complete"] and r["logic_consistent"] for r in document["records"])
        elif words[:3] == ["rosrun", "marl_mrta", "evaluate"]:
            compared = max(runs.glob("evaluate_*.json"), key=lambda path: path.stat().st_mtime)
            assert compared.stat().st_mtime >= started
            summaries = {r["summary"]["method"]: r["summary"] for r in json.loads(compared.read_text())["results"]}
            assert set(summaries) == {"ga", "exact", "policy", "lookahead"}
            # On a floor it never saw: the plans and the generalist complete every task, in order,
            # and none beats the exact plan (the reference proven on this size).
            best = summaries["exact"]["makespan_mean"]
            for summary in summaries.values():
                assert summary["complete_pct"] == 100 and summary["logic_consistent_pct"] == 100, summary
                assert summary["makespan_mean"] >= best - 1e-6, summary
        elif words[:3] == ["rosrun", "marl_mrta", "generate_scenarios"]:
            scenarios = sorted((tmp_path / words[3]).glob("*.xml"))
            assert scenarios and all(load_scenario(path).map_path.resolve() == (tmp_path / "my_floor.yaml").resolve()
                                     for path in scenarios)
        elif words[:3] == ["rosrun", "marl_mrta", "train"]:
            assert (tmp_path / words[words.index("--out") + 1] / "actor.pt").is_file()
