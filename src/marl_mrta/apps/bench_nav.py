"""Benchmark of the navigation (built-in navfn + DWA move_base).

  core     bench_nav_core (no ROS): planning time per plan on the lab map and on TurtleBot3's
           map (turtlebot3_world, when ../shared/... is present), local costmap update and DWA
           controller cycle time;
  tour     the eight task goals of scenarios/lab_2r.xml driven by one robot in the simulator
           (rostest nav_tour.test): per goal, time / (straight-line distance / 0.22 m/s);
  graph    simulator + navigation in lock-step as fast as possible with 2 and 4 robots
           navigating without pause (launch/nav_bench.launch; map -> odom from the simulator, or
           with --localization fake from a fake_localization node per robot): real-time factor, and where the
           time goes (CPU seconds per node; inside move_base: planning, DWA, costmaps, the rest
           being messages, tf and serialisation; all as CPU ms per simulated second), and the
           ceiling of the factor if everything but move_base's computation were free; each
           robot count runs twice: a process per node, and the simulator and every move_base as
           nodelets in one process (nav_bench.launch nodelets:=true), where the manager's CPU time
           is the simulator's and move_base's together;
  ceilings the same ceiling from the isolated cores' times (no other process, no robot in
           view): what TurtleBot3's rates (controller, planner, scans) cost at the least.
Writes <out>/bench_nav.json (headline figures first, as tools/bench_table.py reads them) and
prints a table. Takes a few minutes.

  rosrun marl_mrta bench_nav [--out results] [--robots 2 4] [--sim-seconds 120] [--localization simulator|fake]
                             [--processes nodes nodelets]
"""
import argparse
import glob
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

import rospkg
from roslib.packages import find_node

from marl_mrta.common.paths import package_root
from marl_mrta.common.results import write_result
from marl_mrta.ros.process_group import free_port

MAX_SPEED = 0.22  # [m/s] TurtleBot3 Burger


def navigation_rates(package_dir):
    """Calls per simulated second of a navigating robot, from the parameter files."""
    def load(*parts):
        with open(os.path.join(package_dir, *parts)) as f:
            return yaml.safe_load(f)
    move_base = load("config", "nav", "move_base_params.yaml")
    return {"planning": move_base["planner_frequency"], "dwa": move_base["controller_frequency"],
            "global_costmap": load("config", "nav", "global_costmap_params.yaml")["global_costmap"]["update_frequency"],
            "local_costmap": load("config", "nav", "local_costmap_params.yaml")["local_costmap"]["update_frequency"],
            "scan": load("config", "robot_burger.yaml")["scan_rate"]}


def log(message):
    print(message, flush=True)


def binary(name):
    found = find_node("marl_mrta", name)
    if not found:
        sys.exit("bench_nav: executable '%s' not found: build the package first (make build)" % name)
    return found[0]


def cpu_times():
    """(steal, total) jiffies of all CPUs from /proc/stat: time the hypervisor gave to others."""
    with open("/proc/stat") as f:
        fields = [int(v) for v in f.readline().split()[1:]]
    return fields[7] if len(fields) > 7 else 0, sum(fields[:8])


def run_core(package_dir):
    maps = [os.path.join(package_dir, "maps", "lab.yaml")]
    tb3 = os.path.normpath(os.path.join(package_dir, "..", "shared", "external", "turtlebot3_noetic",
                                        "turtlebot3_navigation", "maps", "map.yaml"))
    if os.path.isfile(tb3):
        maps.append(tb3)
    else:
        log("core: TurtleBot3 map not found at %s: lab map only" % tb3)
    log("core: bench_nav_core on %s" % ", ".join(os.path.basename(os.path.dirname(m)) + "/" + os.path.basename(m)
                                                  for m in maps))
    output = subprocess.run([binary("bench_nav_core"), os.path.join(package_dir, "config", "nav")] + maps,
                            check=True, stdout=subprocess.PIPE, universal_newlines=True).stdout
    results = json.loads(output)
    for entry in results:
        entry["name"] = "turtlebot3_world" if entry["map"] != maps[0] else "lab"
        log("  %-16s plan %.2f ms (p95 %.2f, %d/%d found), local costmap update %.2f ms, DWA cycle %.2f ms" % (
            entry["name"], entry["planning"]["mean_ms"], entry["planning"]["p95_ms"], entry["plans_ok"],
            entry["plans"], entry["local_costmap_update"]["mean_ms"], entry["dwa_cycle"]["mean_ms"]))
    return results


def run_tour(workdir):
    result_file = os.path.join(workdir, "tour.json")
    log("tour: rostest marl_mrta nav_tour.test (one robot, eight task goals)")
    completed = subprocess.run(["rostest", "marl_mrta", "nav_tour.test", "result_file:=" + result_file],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    if completed.returncode != 0 or not os.path.isfile(result_file):
        log(completed.stdout[-3000:])
        sys.exit("bench_nav: the tour failed")
    with open(result_file) as f:
        goals = json.load(f)["goals"]
    for goal in goals:
        goal["efficiency"] = goal["time"] / (goal["straight_line"] / MAX_SPEED)
        log("  %-3s %5.2f m straight, %5.1f s  -> %.2f x the straight-line time at 0.22 m/s" % (
            goal["goal"], goal["straight_line"], goal["time"], goal["efficiency"]))
    total = sum(g["time"] for g in goals) / sum(g["straight_line"] / MAX_SPEED for g in goals)
    log("  tour: %.2f x (expected < 1.5)" % total)
    return {"goals": goals, "efficiency": total}


def run_graph(robots, sim_seconds, workdir, localization, rates, nodelets):
    tag = "%d%s" % (robots, "_nodelets" if nodelets else "")
    stats_dir = os.path.join(workdir, "stats_" + tag)
    os.makedirs(stats_dir, exist_ok=True)
    result_file = os.path.join(workdir, "graph_%s.json" % tag)
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port)
    log("graph: %d robots, lock-step, localization %s, %s, %g s of simulation (roscore on port %d)" % (
        robots, localization, "nodelets in one process" if nodelets else "a process per node", sim_seconds, port))
    completed = subprocess.run(
        ["roslaunch", "-p", str(port), "marl_mrta", "nav_bench.launch", "robots:=%d" % robots,
         "sim_duration:=%g" % sim_seconds, "result_file:=" + result_file, "stats_dir:=" + stats_dir,
         "localization:=" + localization, "nodelets:=%s" % str(nodelets).lower()],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True, timeout=3600)
    if not os.path.isfile(result_file):
        log(completed.stdout[-3000:])
        sys.exit("bench_nav: the %d-robot graph run wrote no result" % robots)
    with open(result_file) as f:
        result = json.load(f)
    # Inside move_base (whole run, summed over robots): CPU seconds and calls of each part.
    per_call = {"planning": ("planning_s", "plans"), "dwa": ("control_s", "control_cycles"),
                "global_costmap": ("global_costmap_s", "global_costmap_updates"),
                "local_costmap": ("local_costmap_s", "local_costmap_updates")}
    totals = {key: [0.0, 0] for key in per_call}
    for path in glob.glob(os.path.join(stats_dir, "move_base_*.json")):
        with open(path) as f:
            stats = json.load(f)
        for key, (seconds, calls) in per_call.items():
            totals[key][0] += stats[seconds]
            totals[key][1] += stats[calls]
    result["localization"] = localization
    result["nodelets"] = nodelets
    result["move_base_inside"] = {k: round(s, 3) for k, (s, c) in totals.items()}
    result["move_base_counts"] = {"plans": totals["planning"][1], "control_cycles": totals["dwa"][1]}
    groups = {}
    for node, seconds in result["cpu_seconds"].items():
        kind = node.rsplit("/", 1)[-1]
        groups[kind] = groups.get(kind, 0.0) + seconds
    result["cpu_seconds_by_node_kind"] = {k: round(v, 3) for k, v in sorted(groups.items(), key=lambda kv: -kv[1])}
    # Where the time goes, in CPU milliseconds per simulated second (whole graph). Inside
    # move_base: the mean CPU time per call (plan, control cycle, costmap update) times the
    # configured rate, i.e. while navigating (its totals cover its whole run, start-up and the
    # idle end included: divided by that run's simulated seconds they would be diluted). Its
    # rest is messages, tf and serialisation; other nodes: CPU seconds over the measured window.
    window = result["sim_seconds"]
    breakdown = {}
    for key, (seconds, calls) in totals.items():
        if calls:
            breakdown["move_base " + key] = 1000.0 * seconds / calls * rates[key] * robots
    result["move_base_ms_per_call"] = {k: round(1000.0 * s / c, 4) for k, (s, c) in totals.items() if c}
    computation = sum(breakdown.values())
    if nodelets:
        # The manager holds the simulator and every move_base; /simulator and /tb3_i/move_base
        # are then only the `nodelet load` clients.
        breakdown["sim_manager: simulator, move_base messages, tf, rest"] = max(
            0.0, 1000.0 * groups.pop("sim_manager", 0.0) / window - computation)
        breakdown["nodelet load clients"] = 1000.0 * (groups.pop("move_base", 0.0) + groups.pop("simulator", 0.0)) / window
    else:
        breakdown["move_base messages, tf, rest"] = max(0.0, 1000.0 * groups.pop("move_base", 0.0) / window - computation)
    for kind, seconds in groups.items():
        breakdown[kind] = 1000.0 * seconds / window
    result["cpu_ms_per_sim_second"] = {k: round(v, 2) for k, v in sorted(breakdown.items(), key=lambda kv: -kv[1])}
    # The real-time factor this machine could not exceed even if messages, tf and the other nodes
    # cost nothing: move_base's own computation spread perfectly over every CPU.
    navigation_ms = sum(breakdown.get("move_base " + k, 0.0) for k in per_call)
    if navigation_ms > 0.0:
        result["compute_only_ceiling"] = {"navigation_cpu_ms_per_sim_second": round(navigation_ms, 2),
                                          "cpus": os.cpu_count(),
                                          "real_time_factor": round(1000.0 * os.cpu_count() / navigation_ms, 1)}
    log("  real-time factor %.1f x over %.0f s of simulation (%.1f s wall); goals %s" % (
        result["real_time_factor"], result["sim_seconds"], result["wall_seconds"], result["goal_outcomes"]))
    log("  CPU seconds per node kind: " + ", ".join("%s %.1f" % kv for kv in result["cpu_seconds_by_node_kind"].items()))
    log("  inside move_base (whole run): " + ", ".join("%s %.1f s" % kv for kv in result["move_base_inside"].items()))
    log("  CPU ms per simulated second: " + ", ".join("%s %.1f" % kv for kv in result["cpu_ms_per_sim_second"].items()))
    if "compute_only_ceiling" in result:
        log("  ceiling with free messages (navigation computation on %d CPUs): %.1f x" % (
            os.cpu_count(), result["compute_only_ceiling"]["real_time_factor"]))
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default=str(package_root() / "results"), help="directory of bench_nav.json")
    parser.add_argument("--robots", type=int, nargs="+", default=[2, 4], help="robot counts of the graph runs")
    parser.add_argument("--sim-seconds", type=float, default=120.0, help="simulated seconds measured per graph run")
    parser.add_argument("--localization", choices=["simulator", "fake"], default="simulator",
                        help="map -> odom from the simulator itself, or from a fake_localization node per robot")
    parser.add_argument("--processes", choices=["nodes", "nodelets"], nargs="+", default=["nodes", "nodelets"],
                        help="graph runs with a process per node, and/or with the simulator and move_base as nodelets")
    args = parser.parse_args()
    package_dir = os.path.realpath(rospkg.RosPack().get_path("marl_mrta"))
    os.makedirs(args.out, exist_ok=True)
    # Other processes on the machine lower the real-time factor (the CPU figures less so).
    load_before = os.getloadavg()[0]
    steal_before, total_before = cpu_times()
    with tempfile.TemporaryDirectory(prefix="bench_nav_") as workdir:
        core = run_core(package_dir)
        tour = run_tour(workdir)
        rates = navigation_rates(package_dir)
        graphs = {mode: {str(n): run_graph(n, args.sim_seconds, workdir, args.localization, rates, mode == "nodelets")
                         for n in args.robots} for mode in args.processes}
    # The least TurtleBot3's rates cost: the isolated cores' times on the lab map, costmap
    # updates counted only when a scan arrives.
    lab = core[0]
    per_robot_ms = (lab["dwa_cycle"]["mean_ms"] * rates["dwa"] + lab["planning"]["mean_ms"] * rates["planning"] +
                    (lab["global_costmap_update_with_scan"]["mean_ms"] + lab["local_costmap_update"]["mean_ms"]) *
                    rates["scan"])
    core_ceiling = {"rates_per_sim_second": rates, "navigation_cpu_ms_per_robot_sim_second": round(per_robot_ms, 3),
                    "cpus": os.cpu_count(),
                    "real_time_factor": {str(n): round(1000.0 * os.cpu_count() / (n * per_robot_ms), 1)
                                         for n in args.robots}}
    log("ceiling from the isolated cores: %.2f CPU ms per robot and simulated second -> %s" % (
        per_robot_ms, ", ".join("%s robots %.0f x" % kv for kv in core_ceiling["real_time_factor"].items())))
    headline = [{"figure": "tour time / straight-line time at 0.22 m/s", "value": round(tour["efficiency"], 3),
                 "unit": "x", "goal": "< 1.5"}]
    for mode, label in (("nodes", ""), ("nodelets", ", nodelets")):
        for n, graph in graphs.get(mode, {}).items():
            headline.append({"figure": "real-time factor, sim + nav, %s robots, lock-step%s" % (n, label),
                             "value": round(graph["real_time_factor"], 1), "unit": "x", "goal": ">= 100"})
    for n, graph in graphs.get("nodes", {}).items():
        if "compute_only_ceiling" in graph:
            headline.append({"figure": "ceiling of that factor with free messages, %s robots" % n,
                             "value": graph["compute_only_ceiling"]["real_time_factor"], "unit": "x", "goal": ""})
    for n, factor in core_ceiling["real_time_factor"].items():
        headline.append({"figure": "ceiling from the isolated cores, %s robots" % n, "value": factor, "unit": "x",
                         "goal": ""})
    for entry in core:
        headline.append({"figure": "planning time per plan, %s map" % entry["name"],
                         "value": round(entry["planning"]["mean_ms"], 3), "unit": "ms", "goal": ""})
    headline.append({"figure": "DWA controller cycle", "value": round(core[0]["dwa_cycle"]["mean_ms"], 3),
                     "unit": "ms", "goal": ""})
    steal_after, total_after = cpu_times()
    machine = {"cpus": os.cpu_count(), "platform": platform.platform(),
               "load_average_1min": {"before": round(load_before, 2), "after": round(os.getloadavg()[0], 2)},
               # On a virtual machine: the share of CPU time the host gave to others meanwhile.
               "cpu_steal_fraction": round((steal_after - steal_before) / max(1, total_after - total_before), 3)}
    report = {"headline": headline, "machine": machine,
              "core": core, "core_ceiling": core_ceiling, "tour": tour, "graph": graphs.get("nodes", {}),
              "graph_nodelets": graphs.get("nodelets", {})}
    path = os.path.join(args.out, "bench_nav.json")
    write_result(Path(path), report)
    log("\n%-55s %10s  %s" % ("figure", "value", "goal"))
    for row in headline:
        log("%-55s %8.3g %-2s %s" % (row["figure"], row["value"], row["unit"], row["goal"]))
    log("machine load (1 min average) before / after: %.1f / %.1f on %d CPUs; CPU time stolen by the host: %.0f %%" % (
        load_before, machine["load_average_1min"]["after"], os.cpu_count(), 100.0 * machine["cpu_steal_fraction"]))
    log("wrote " + path)
