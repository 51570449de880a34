"""Benchmark: the built-in navigation held against the stock ROS navigation stack on the same legs.

Per map, seeded legs (evaluation/nav_comparison.py: start and goal on free cells away from
obstacles) are driven by one robot in the simulator running freely at the real-time factor
(launch/nav_legs.launch: no lock-step, which the stock nodes do not take part in), once with
nav:=builtin and once with nav:=stock, the same parameter files, map -> odom from the simulator,
each leg `--repeats` times (on tb3_world the first leg is issue 18's pillar leg, FIXED_LEGS). A stock
success reported at once away from the goal (ros-planning/navigation#949) has its goal sent
again (LegRecord.resent). Per leg: success, time, path length; per map: success rates and the
median and maximum per-leg time ratio built-in ÷ stock (medians over the repeats). Then the
localisation: on `--loc-maps`, the stacks' own particle filters (marl_mrta/amcl against stock
amcl, localization:=amcl) on the same legs under noise_profile:=measured_tb3 (odometry drift on):
mean and maximum error of amcl_pose against the ground truth, CPU time of the filter per update.

Writes <out>/bench_nav_vs_stock.json (headline figures first, tools/bench_table.py) and prints
a table with what misses the goals (docs/guide/navigation.md). Without the
stock packages (make stock-nav) it says so in one line and writes nothing.

  rosrun marl_mrta bench_nav_vs_stock [--out results] [--maps lab tb3_world] [--legs 4] [--repeats 3]
      [--loc-maps lab] [--loc-legs 2] [--seed 0] [--rtf 1] [--goal-timeout 120]
The defaults (every map, 4 legs x 3 drives per stack: a leg's time is the median of its three,
since single drives vary by up to 30 %) take about 67 min of wall time on 2 cores; --repeats 1
about 25 min.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import xmlrpc.client
import zlib
from dataclasses import asdict, replace
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

import rosgraph
import rospkg

from marl_mrta.common.paths import package_root
from marl_mrta.common.results import write_result
from marl_mrta.evaluation.nav_comparison import (STACKS, Leg, LegRecord, LegRequest, LocalisationSummary,
                                                 MapComparison, compare_map, draw_legs, headline, leg_time)
from marl_mrta.model.occupancy_map import load_map
from marl_mrta.ros.process_group import free_port, stop_process_group

STOCK_PACKAGES = ("move_base", "amcl", "map_server")
MAP_NAMES = ("lab", "tb3_world", "corridors", "pillars", "doors")
#: The default run: every map (10 launches of 4 legs, 2 of 2 for the localisation).
DEFAULT_MAPS = MAP_NAMES
DEFAULT_LOC_MAPS = ("lab",)
#: s of wall time a launch may take beyond its legs (start-up, resets, relocalisation, shut-down).
LAUNCH_OVERHEAD = 120.0
#: s of wall time within which a launch that ends without a result failed to start (started again).
STARTUP_WALL = 60.0
START_RETRIES = 1


def log(message: str) -> None:
    print(message, flush=True)


def stock_available() -> bool:
    known = rospkg.RosPack().list()
    return all(p in known for p in STOCK_PACKAGES)


def map_files() -> Dict[str, Path]:
    """The maps the harness knows, by name: the lab, TurtleBot3's turtlebot3_world (beside the
    checkout in ../shared), and the corridors, pillars and doors of the package's test data."""
    root = package_root()
    data = root / "test" / "data" / "nav_compare"
    candidates = {"lab": root / "maps" / "lab.yaml",
                  "tb3_world": root.parent / "shared" / "external" / "turtlebot3_noetic" / "turtlebot3_navigation" / "maps" /
                  "map.yaml",
                  "corridors": data / "corridors.yaml", "pillars": data / "pillars.yaml", "doors": data / "doors.yaml"}
    return {name: path for name, path in candidates.items() if path.is_file()}


#: Legs every run drives first on a map, before the drawn ones (counted in --legs). On
#: turtlebot3_world: from between the pillars (the 3 x 3 grid at -1.1, 0, 1.1 m) to a goal just
#: north of the grid facing +y, where the built-in move_base was once seen oscillating in a
#: three-robot episode. On doors: into the dead-end pocket of the middle room (0.9 m wide, open to
#: the south) through the west door, facing its closed end; then out of it, turning on the spot
#: there, through the east door.
FIXED_LEGS: Dict[str, Tuple[Leg, ...]] = {
    "tb3_world": (Leg((0.0, 0.55, 3.1416), (0.55, 1.6, 1.5708), 18),),
    "doors": (Leg((1.3, 2.5, 0.0), (4.0, 2.55, 1.5708), 21), Leg((4.0, 2.55, 1.5708), (6.6, 4.2, 0.0), 22)),
}


def legs_of(name: str, path: Path, count: int, seed: int) -> List[Leg]:
    """The map's legs: its fixed legs, then legs drawn from the seed and the map's name, so a
    map's legs do not depend on which other maps run."""
    fixed = list(FIXED_LEGS.get(name, ()))[:count]
    drawn = draw_legs(load_map(path), LegRequest(count=count - len(fixed), seed=seed * 1000003 + zlib.crc32(name.encode())))
    return fixed + drawn


def last_line(path: str) -> str:
    """The last line of a launch's log that says something (ANSI colours removed)."""
    with open(path, errors="replace") as f:
        lines = [re.sub(r"\x1b\[[0-9;]*m|\x1b\]2;[^\x07]*\x07", "", line).strip() for line in f]
    lines = [line for line in lines if line and not line.startswith(("[", "...", "---", "shutting", "done"))] or [""]
    return lines[-1][:300]


def stop_leftover_master(port: int) -> None:
    """After a launch ended: a master (and its rosout) still up on the launch's port is stopped. A
    launch that fails while starting (e.g. `REQUIRED process ... has died` before every node ran)
    ends without stopping them, and each runs in a process group of its own."""
    uri = f"http://127.0.0.1:{port}"
    try:
        master = rosgraph.Master("/bench_nav_vs_stock", master_uri=uri)
        pids = [int(xmlrpc.client.ServerProxy(master.lookupNode("/rosout")).getPid("/bench_nav_vs_stock")[2])]
    except (OSError, xmlrpc.client.Error, rosgraph.MasterError, ValueError, TypeError):
        pids = []
    try:
        pids.append(rosgraph.Master("/bench_nav_vs_stock", master_uri=uri).getPid())
    except (OSError, xmlrpc.client.Error, rosgraph.MasterError):
        return   # no master there: roslaunch stopped it
    for pid in pids:
        try:
            os.kill(pid, signal.SIGINT)
        except OSError:
            pass
    log(f"  stopped the master left on port {port} (processes {', '.join(map(str, pids))})")


def run_stack(stack: str, map_path: Path, legs: Sequence[Leg], repeats: int, localization: str, noise_profile: str,
              rtf: float, goal_timeout: float, workdir: str, tag: str,
              lockstep: bool = False) -> Tuple[List[LegRecord], str]:
    """One launch of nav_legs.launch: every leg `repeats` times in turn. Returns the records
    (LegRecord.index = the leg's index) and an error ('' when every drive ran). `lockstep` (the
    built-in stack only; with rtf 0): a deterministic screening run, as fast as the machine goes."""
    result_file = os.path.join(workdir, f"{tag}_{stack}.json")
    drives = [leg.as_list() for _ in range(repeats) for leg in legs]
    command = ["roslaunch", "-p", "PORT", "marl_mrta", "nav_legs.launch", f"nav:={stack}", f"map:={map_path}",
               f"legs:={json.dumps(drives)}", f"result_file:={result_file}", f"localization:={localization}",
               f"noise_profile:={noise_profile}", f"rtf:={rtf:g}", f"goal_timeout:={goal_timeout:g}",
               f"lockstep:={str(lockstep).lower()}"]
    wall_limit = LAUNCH_OVERHEAD + len(drives) * (goal_timeout + 15.0) / max(rtf, 0.1)
    log_path = os.path.join(workdir, f"{tag}_{stack}.log")
    for attempt in range(1 + START_RETRIES):
        port = free_port()
        command[2] = str(port)
        with open(log_path, "a") as out:
            out.write(f"--- attempt {attempt + 1}: {' '.join(command)}\n")
            out.flush()
            started = time.monotonic()
            process = subprocess.Popen(command, env=dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}"),
                                       stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
            try:
                process.wait(wall_limit)
            except subprocess.TimeoutExpired:
                stop_process_group(process)
                stop_leftover_master(port)
                return [], f"{tag} {stack}: the launch did not end within {wall_limit:.0f} s of wall time (log: {log_path})"
            stop_leftover_master(port)
        # A graph that did not come up (no result, the launch over within its start-up) is started
        # again once; one that drove and then wrote nothing is an error.
        if os.path.isfile(result_file) or time.monotonic() - started > STARTUP_WALL:
            break
        log(f"  {tag} {stack}: the launch ended after {time.monotonic() - started:.0f} s without a result "
            f"(exit {process.returncode}): {last_line(log_path)}" + ("; again" if attempt < START_RETRIES else ""))
    if not os.path.isfile(result_file):
        return [], f"{tag} {stack}: the driver wrote no result (log: {log_path}): {last_line(log_path)}"
    with open(result_file) as f:
        result = json.load(f)
    # The driver counts drives; a drive's leg is its position in the list of one pass.
    records = [replace(record, index=record.index % len(legs)) for record in map(LegRecord.from_dict, result["legs"])]
    error = result.get("error", "")
    if not error and len(records) < len(drives):
        error = f"{tag} {stack}: {len(records)} of {len(drives)} drives"
    return records, error


def describe_map(comparison: MapComparison, runs: Dict[str, List[LegRecord]], legs: Sequence[Leg]) -> None:
    log(f"  {comparison.map}: success built-in {comparison.success['builtin']:.2f}, stock {comparison.success['stock']:.2f}"
        + (f"; time ratio median {comparison.median_ratio:.3f}, max {comparison.max_ratio:.3f}"
           if comparison.median_ratio is not None else ""))
    for i, leg in enumerate(legs):
        times = {s: leg_time([r for r in runs[s] if r.index == i]) for s in STACKS}
        resent = [s for s in STACKS if any(r.resent for r in runs[s] if r.index == i)]
        log("    leg %d (%.1f m straight): built-in %s, stock %s, ratio %s%s" % (
            i, leg.straight_line, *("%.1f s" % times[s] if times[s] is not None else "failed" for s in STACKS),
            "%.2f" % comparison.ratios[i] if comparison.ratios[i] is not None else "-",
            "; goal sent again after a stale success (ros-planning/navigation#949): " + ", ".join(resent)
            if resent else ""))


def compare_navigation(names: Sequence[str], maps: Dict[str, Path], count: int, repeats: int, seed: int, rtf: float,
                       goal_timeout: float, workdir: str, localization: str = "simulator",
                       noise_profile: str = "ideal") -> Tuple[List[dict], List[str]]:
    """Both stacks on every map of `names`; per map its legs, drives, comparison and errors."""
    reports, errors = [], []
    for name in names:
        legs = legs_of(name, maps[name], count, seed)
        runs: Dict[str, List[LegRecord]] = {}
        for stack in STACKS:
            log(f"{name}: {stack}, {len(legs)} legs x {repeats}, localization {localization}, noise {noise_profile}")
            started = time.monotonic()
            runs[stack], error = run_stack(stack, maps[name], legs, repeats, localization, noise_profile, rtf,
                                           goal_timeout, workdir, f"{name}_{localization}")
            log(f"  {len(runs[stack])} drives in {time.monotonic() - started:.0f} s of wall time" +
                (f"; {error}" if error else ""))
            if error:
                errors.append(error)
        report = {"map": name, "legs": [leg.as_list() for leg in legs],
                  "drives": {stack: [r.to_dict() for r in runs[stack]] for stack in STACKS}}
        if all(len(runs[s]) == len(legs) * repeats for s in STACKS):
            comparison = compare_map(name, len(legs), runs)
            describe_map(comparison, runs, legs)
            report["comparison"] = comparison.to_dict()
            report["misses"] = comparison.misses()
        reports.append(report)
    return reports, errors


def localisation_summaries(reports: Sequence[dict]) -> Dict[str, Dict[str, LocalisationSummary]]:
    summaries: Dict[str, Dict[str, LocalisationSummary]] = {}
    for report in reports:
        for stack in STACKS:
            summary = LocalisationSummary.of([LegRecord.from_dict(d) for d in report["drives"][stack]])
            if summary is not None:
                summaries.setdefault(report["map"], {})[stack] = summary
    return summaries


def run(args: argparse.Namespace) -> Optional[dict]:
    """The benchmark (or the CI test's short form); None when the stock stack is missing."""
    if not stock_available():
        log("bench_nav_vs_stock: skipped: stock navigation not available (no move_base/amcl package; make stock-nav)")
        return None
    maps = map_files()
    for name in set(args.maps) | set(args.loc_maps):
        if name not in maps:
            log(f"bench_nav_vs_stock: map {name} not found: left out")
    load_before = os.getloadavg()[0]
    started = time.monotonic()
    # The launches' logs: removed when every launch ran, kept (and named) otherwise.
    workdir = tempfile.mkdtemp(prefix="bench_nav_vs_stock_")
    navigation, errors = compare_navigation([n for n in args.maps if n in maps], maps, args.legs, args.repeats,
                                            args.seed, args.rtf, args.goal_timeout, workdir)
    localisation, loc_errors = compare_navigation([n for n in args.loc_maps if n in maps], maps, args.loc_legs, 1,
                                                  args.seed, args.rtf, args.goal_timeout, workdir, "amcl",
                                                  "measured_tb3")
    if errors or loc_errors:
        log(f"bench_nav_vs_stock: the launches' logs are kept in {workdir}")
    else:
        shutil.rmtree(workdir, ignore_errors=True)
    summaries = localisation_summaries(localisation)
    for map_name, stacks in summaries.items():
        for stack, s in stacks.items():
            log(f"  {map_name} {stack} amcl: error mean {s.mean_xy:.3f} m / {s.mean_yaw:.3f} rad, max {s.max_xy:.3f} m / "
                f"{s.max_yaw:.3f} rad over {s.estimates} estimates; CPU per update "
                + (f"{1e3 * s.cpu_per_update:.2f} ms" if s.cpu_per_update is not None else "-"))
    comparisons = [MapComparison(**{k: r["comparison"][k] for k in ("map", "legs", "success", "ratios", "stock_only")})
                   for r in navigation if "comparison" in r]
    return {"headline": headline(comparisons, summaries),
            "misses": [m for r in navigation for m in r.get("misses", [])], "errors": errors + loc_errors,
            "settings": {"maps": args.maps, "legs": args.legs, "repeats": args.repeats, "loc_maps": args.loc_maps,
                         "loc_legs": args.loc_legs, "seed": args.seed, "rtf": args.rtf, "goal_timeout": args.goal_timeout},
            "wall_time_s": round(time.monotonic() - started, 1),
            "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                        "load_average_1min": {"before": round(load_before, 2), "after": round(os.getloadavg()[0], 2)}},
            "navigation": navigation,
            "localisation": {"summaries": {m: {s: asdict(v) for s, v in stacks.items()} for m, stacks in summaries.items()},
                             "maps": localisation}}


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default=str(package_root() / "results"), help="directory of bench_nav_vs_stock.json")
    p.add_argument("--maps", nargs="+", default=list(DEFAULT_MAPS), choices=MAP_NAMES,
                   help="maps of the navigation comparison (default: %(default)s)")
    p.add_argument("--legs", type=int, default=4, help="legs per map")
    p.add_argument("--repeats", type=int, default=3, help="drives per leg and stack (the leg's time is their median)")
    p.add_argument("--loc-maps", nargs="*", default=list(DEFAULT_LOC_MAPS), choices=MAP_NAMES,
                   help="maps of the localisation comparison (none: left out; default: %(default)s)")
    p.add_argument("--loc-legs", type=int, default=2, help="legs per map of the localisation comparison")
    p.add_argument("--seed", type=int, default=0, help="seed of the legs")
    p.add_argument("--rtf", type=float, default=1.0, help="the simulator's real-time factor")
    p.add_argument("--goal-timeout", type=float, default=120.0,
                   help="s of sim time a goal may take (legs are at most 4 m apart in a straight line; round the "
                        "serpentine of the corridors map a path is up to 12 m: about 60 s of driving)")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = parser().parse_args(argv)
    report = run(args)
    if report is None:
        return 0
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "bench_nav_vs_stock.json")
    write_result(Path(path), report)
    log("\n%-60s %10s  %s" % ("figure", "value", "goal"))
    for row in report["headline"]:
        log("%-60s %8.3g %-8s %s" % (row["figure"], row["value"], row["unit"], row["goal"]))
    for line in report["misses"] + report["errors"]:
        log("miss: " + line if line in report["misses"] else "error: " + line)
    log("wrote " + path)
    return 1 if report["errors"] else 0


if __name__ == "__main__":
    sys.exit(main())
