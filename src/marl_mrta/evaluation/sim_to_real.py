"""The sim-to-real figures from what a run recorded, without ROS: localisation error (amcl's
estimates against the stand-in's ground truth file), command-to-motion latency (cmd_vel against
odometry) and stop latency (when every later command of a robot is zero), a report row of each
run and the report's plot (apps/sim_to_real.py runs the launches). Times in seconds of the run's
clock (wall time on robots and the stand-in, sim time in the simulation).
"""
from __future__ import annotations

import bisect
import csv
import math
from pathlib import Path
from typing import Dict, Iterable, List, Optional, Sequence, Tuple

from marl_mrta.model.occupancy_map import OccupancyMap

ROBOTS = ("tb3_0", "tb3_1")
ROWS = {"sim_ideal": "simulation, lock-step, ideal", "sim_measured": "simulation, lock-step, measured_tb3",
        "stand_in": "real.launch, stand-in (wall time, amcl)"}
FAULTS = ("robot_killed", "ctrl_c", "estop", "move_base_abort", "manager_hung", "mislocalised",
          "master_lost")   # master_lost ends the master: last
PAPER = {"simulation": 42.0, "real": 60.0}   # Table 10: makespan [s] of MAPPO, 2 robots

Track = List[Tuple[float, float, float, float]]   # (t, x, y, yaw), sorted by t
Sample = Tuple[float, float, float]                # (t, linear, angular)

#: A command or odometry reading counts as motion above these [m/s], [rad/s].
MOVING_LINEAR = 0.01
MOVING_ANGULAR = 0.05


def displaced_position(occupancy_map: OccupancyMap, x: float, y: float, distance: float,
                       clearance: float = 0.3) -> Tuple[float, float]:
    """A free point `distance` m from (x, y), at least `clearance` m from the map's obstacles:
    where a mislocalisation fault tells amcl the robot stands (navigation then plans from there
    rather than failing at once in an obstacle)."""
    clear = occupancy_map.clearance()
    for k in range(16):
        angle = 2.0 * math.pi * k / 16
        px, py = x + distance * math.cos(angle), y + distance * math.sin(angle)
        cell = occupancy_map.world_to_cell(px, py)
        if cell is not None and clear[cell.row, cell.col] > clearance:
            return px, py
    raise ValueError(f"no free point {distance:g} m from ({x:.2f}, {y:.2f})")


def read_ground_truth(paths: Iterable[Path]) -> Dict[str, Track]:
    """The stand-in's CSV files (kind,stamp,robot,x,y,yaw,...): every robot's true poses."""
    tracks: Dict[str, Track] = {}
    for path in paths:
        with open(path, newline="") as stream:
            for row in csv.DictReader(stream):
                if row["kind"] == "pose":
                    tracks.setdefault(row["robot"], []).append(
                        (float(row["stamp"]), float(row["x"]), float(row["y"]), float(row["yaw"])))
    for track in tracks.values():
        track.sort()
    return tracks


def angle_diff(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


def pose_at(track: Track, t: float, max_gap: float = 0.2) -> Optional[Tuple[float, float, float]]:
    """The true pose at `t`, interpolated between the two records around it (None when `t` is
    outside the track or the records around it are more than `max_gap` s apart)."""
    times = [p[0] for p in track]
    k = bisect.bisect_left(times, t)
    if k == 0 or k == len(track):
        return None
    (t0, x0, y0, a0), (t1, x1, y1, a1) = track[k - 1], track[k]
    if t1 - t0 > max_gap:
        return None
    w = (t - t0) / (t1 - t0) if t1 > t0 else 0.0
    da = (a1 - a0 + math.pi) % (2.0 * math.pi) - math.pi
    return x0 + w * (x1 - x0), y0 + w * (y1 - y0), a0 + w * da


def localisation_errors(estimates: Sequence[Tuple[float, float, float, float]], track: Track) -> List[Tuple[float, float]]:
    """(position error [m], heading error [rad]) of every estimate (t, x, y, yaw) within the track."""
    errors = []
    for t, x, y, yaw in estimates:
        truth = pose_at(track, t)
        if truth is not None:
            errors.append((math.hypot(x - truth[0], y - truth[1]), angle_diff(yaw, truth[2])))
    return errors


def is_moving(linear: float, angular: float) -> bool:
    return abs(linear) > MOVING_LINEAR or abs(angular) > MOVING_ANGULAR


def stop_time(commands: Sequence[Sample], after: float) -> Optional[float]:
    """When a robot was stopped for good after `after`: the first zero command after which every
    command is zero (None if it was still commanded to move at the end, or got no zero at all)."""
    stopped = None
    for t, linear, angular in commands:
        if t < after:
            continue
        if is_moving(linear, angular):
            stopped = None
        elif stopped is None:
            stopped = t
    return stopped


def motion_latencies(commands: Sequence[Sample], odometry: Sequence[Sample]) -> List[float]:
    """For every command that sets a standing robot moving, the time until the odometry first
    shows motion: the command-to-motion latency of the base (and its transport)."""
    odom_times = [o[0] for o in odometry]
    latencies = []
    moving = False
    for t, linear, angular in commands:
        now_moving = is_moving(linear, angular)
        if now_moving and not moving:
            k = bisect.bisect_right(odom_times, t)
            # The base must have stood still at the command: its previous reading shows no motion.
            if 0 < k < len(odometry) and not is_moving(odometry[k - 1][1], odometry[k - 1][2]):
                for o in odometry[k:]:
                    if is_moving(o[1], o[2]):
                        latencies.append(o[0] - t)
                        break
        moving = now_moving
    return latencies


def summary(values: Sequence[float]) -> Dict[str, Optional[float]]:
    """count, mean, median, 95th percentile and max of `values` (None each when there are none)."""
    if not values:
        return {"count": 0, "mean": None, "median": None, "p95": None, "max": None}
    ordered = sorted(values)
    return {"count": len(ordered), "mean": sum(ordered) / len(ordered), "median": ordered[len(ordered) // 2],
            "p95": ordered[min(len(ordered) - 1, int(math.ceil(0.95 * len(ordered))) - 1)], "max": ordered[-1]}


def row_figures(kind: str, run: Dict) -> Dict:
    """A report row: `run` holds the result document, the probe's recordings and the ground truth."""
    result = run["result"]
    if "results" in result:   # evaluate's document
        part = result["results"][0]
        summary_, episodes, record, seconds = part["summary"], part["episodes"], part["representative_episode"], part["seconds"]
    else:                     # rl_manager execute's
        summary_, episodes, record, seconds = result["summary"], result["records"], result["representative_episode"], result["seconds"]
    latencies, loc_xy, loc_yaw = [], [], []
    for ns in ROBOTS:
        rec = run["probe"][ns]
        latencies += motion_latencies([tuple(r) for r in rec["cmd_vel"]], [tuple(r) for r in rec["odom"]])
        track = run["ground_truth"].get(ns)
        if track and rec["amcl_pose"]:
            errors = localisation_errors([tuple(r) for r in rec["amcl_pose"]], track)
            loc_xy += [e[0] for e in errors]
            loc_yaw += [e[1] for e in errors]
    return {"label": ROWS[kind], "makespan": summary_["makespan_mean"], "complete_pct": summary_["complete_pct"],
            "logic_consistent_pct": summary_["logic_consistent_pct"], "allocation": summary_["allocation"],
            "episodes": len(episodes), "abort_reason": record["abort_reason"],
            "wall_seconds": seconds / max(1, len(episodes)),   # per episode, its reset included
            "command_to_motion_s": summary(latencies), "localisation_error_m": summary(loc_xy),
            "localisation_error_rad": summary(loc_yaw),
            "localisation": "amcl vs the stand-in's ground truth" if loc_xy else "ground truth (the simulator's)"}


def plot(report: Dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = report["rows"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    labels = ["paper\nsimulation", "paper\nreal robots"] + [r.replace(", ", "\n") for r in
                                                            (rows[k]["label"] for k in ROWS if k in rows)]
    values = [PAPER["simulation"], PAPER["real"]] + [rows[k]["makespan"] for k in ROWS if k in rows]
    axes[0].bar(range(len(values)), values, color=["#bbbbbb", "#888888"] + ["#4c72b0", "#dd8452", "#55a868"][:len(values) - 2])
    axes[0].set_xticks(range(len(values)))
    axes[0].set_xticklabels(labels, fontsize=7)
    axes[0].set_ylabel("makespan (s)")
    axes[0].set_title("sim-to-real: makespan of the learned policy")
    faults = report.get("faults", {})
    names = [k for k in FAULTS if k in faults and faults[k].get("worst_s") is not None]
    axes[1].bar(range(len(names)), [faults[k]["worst_s"] for k in names], color="#c44e52")
    axes[1].axhline(0.5, color="black", linestyle="--", linewidth=1, label="bound 0.5 s")
    axes[1].set_xticks(range(len(names)))
    axes[1].set_xticklabels([n.replace("_", "\n") for n in names], fontsize=7, rotation=30)
    axes[1].set_ylabel("s from the fault known to every robot stopped")
    axes[1].set_title("stop latency per failure kind (worst robot)")
    axes[1].legend()
    walls = [(rows[k]["label"].replace(", ", "\n"), rows[k]["wall_seconds"]) for k in ROWS if k in rows]
    axes[2].bar(range(len(walls)), [w for _, w in walls], color=["#4c72b0", "#dd8452", "#55a868"][:len(walls)])
    axes[2].set_xticks(range(len(walls)))
    axes[2].set_xticklabels([n for n, _ in walls], fontsize=7)
    axes[2].set_ylabel("wall s per episode (incl. reset)")
    axes[2].set_title("wall time of an episode")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
