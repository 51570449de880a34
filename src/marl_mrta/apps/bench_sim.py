"""Benchmark of the simulator: real-time factor of the core alone and of the node.

For 2, 4, 8 and 16 robots (one arena, lidar 5 Hz, physics 20 Hz):
  core  bench_sim_core (no ROS, one thread): sim seconds per wall second, with and without
        the lidar, hence the share of ray casting and of physics;
  node  the `simulator` node at rtf 0 against its own roscore, with a subscriber to every
        topic it publishes (bench_sim_sink), so that every message is serialised and sent:
        its real-time factor and the share of stepping the core vs publishing.
Writes <out>/bench_sim.json (headline figures first, as tools/bench_table.py reads them) and
prints a table. Takes about a minute.

  rosrun marl_mrta bench_sim [--out results] [--robots 2 4 8 16] [--sim-seconds 300]
"""
import argparse
import json
import os
import platform
import resource
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import rosgraph
import rospkg
import rospy
import yaml
from roslib.packages import find_node
from std_srvs.srv import SetBool

from marl_mrta.common.results import write_result


def binary(name):
    found = find_node("marl_mrta", name)
    if not found:
        sys.exit("bench_sim: executable '%s' not found: build the package first (make build)" % name)
    return found[0]


def log(message):
    print(message, flush=True)


def run_core(map_yaml, robot_counts):
    log("core: bench_sim_core %s %s" % (map_yaml, " ".join(map(str, robot_counts))))
    output = subprocess.run([binary("bench_sim_core"), map_yaml] + [str(n) for n in robot_counts],
                            check=True, stdout=subprocess.PIPE, universal_newlines=True).stdout
    results = {}
    for line in output.splitlines():
        entry = json.loads(line)
        results[entry["robots"]] = entry
        log("  %2d robots: %8.0f x real time per CPU second, %8.0f per wall second (%.0f%% ray casting)" % (
            entry["robots"], entry["rtf_cpu"], entry["rtf"], 100 * entry["raycast_share"]))
    return results


class Roscore:
    """A private roscore on a free port, so that the benchmark never meets another graph."""

    def __enter__(self):
        with socket.socket() as s:
            s.bind(("localhost", 0))
            port = s.getsockname()[1]
        self.uri = "http://localhost:%d" % port
        os.environ["ROS_MASTER_URI"] = self.uri
        self.process = subprocess.Popen(["roscore", "-p", str(port)], stdout=subprocess.DEVNULL,
                                        stderr=subprocess.DEVNULL, start_new_session=True)
        deadline = time.monotonic() + 30
        while not rosgraph.Master("/bench_sim").is_online():
            if time.monotonic() > deadline:
                sys.exit("bench_sim: roscore did not start")
            time.sleep(0.2)
        return self

    def __exit__(self, *exc):
        self.process.terminate()
        self.process.wait(10)


def run_node(map_yaml, robots, start_poses, sim_seconds, config_file, workdir):
    master = rosgraph.Master("/bench_sim")
    # As sim.launch loads them: the Burger (config/robot_burger.yaml), then the simulator's own file.
    params = {}
    for path in (os.path.join(os.path.dirname(config_file), "robot_burger.yaml"), config_file):
        with open(path) as f:
            params.update(yaml.safe_load(f) or {})
    stats_file = os.path.join(workdir, "node_%d.json" % robots)
    params.update(map_file=map_yaml, robots=robots, start_poses=start_poses, rtf=0.0, start_paused=True,
                  stop_after=float(sim_seconds), stats_file=stats_file)
    master.setParam("/simulator", params)
    names = ["tb3_%d" % i for i in range(robots)]
    sink = subprocess.Popen([binary("bench_sim_sink")] + names, stdout=subprocess.PIPE, universal_newlines=True)
    simulator = subprocess.Popen([binary("simulator")], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                 universal_newlines=True)
    time.sleep(2.0)  # subscribers connect while the simulator waits, paused
    rospy.wait_for_service("/simulator/pause", timeout=30)
    rospy.ServiceProxy("/simulator/pause", SetBool)(False)
    cpu_before = resource.getrusage(resource.RUSAGE_CHILDREN)
    _, errors = simulator.communicate(timeout=600)
    cpu_after = resource.getrusage(resource.RUSAGE_CHILDREN)  # the simulator is the only child reaped since
    node_cpu = (cpu_after.ru_utime + cpu_after.ru_stime) - (cpu_before.ru_utime + cpu_before.ru_stime)
    if simulator.returncode != 0:
        sys.exit("bench_sim: simulator failed: %s" % errors.strip())
    counts = json.loads(sink.communicate(timeout=30)[0])
    with open(stats_file) as f:
        stats = json.load(f)
    ticks = sim_seconds * params["physics_rate"]
    published = ticks * (2 + robots * 2 + 1) + (sim_seconds * params["scan_rate"]) * robots  # clock, tick, odom, gt, tf, scans
    received = sum(counts.values())
    stats.update(cpu_seconds=node_cpu, rtf_cpu=stats["sim_seconds"] / node_cpu,
                 simulate_share=stats["simulate_seconds"] / stats["wall_seconds"],
                 publish_share=stats["publish_seconds"] / stats["wall_seconds"],
                 messages_published=int(published), messages_received_by_sink=received)
    log("  %2d robots: %8.0f x real time per wall second, %8.0f per CPU second (%.0f%% stepping the core, "
        "%.0f%% publishing; sink received %.0f%%)" % (robots, stats["rtf"], stats["rtf_cpu"], 100 * stats["simulate_share"],
                                                     100 * stats["publish_share"], 100.0 * received / published))
    return stats


def main():
    package = rospkg.RosPack().get_path("marl_mrta")
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[2, 4, 8, 16], help="robot counts to measure")
    parser.add_argument("--sim-seconds", type=float, default=300.0, help="sim time per node run")
    parser.add_argument("--map", default=os.path.join(package, "maps", "lab.yaml"), help="map_server YAML")
    parser.add_argument("--config", default=os.path.join(package, "config", "sim.yaml"), help="simulator parameters")
    parser.add_argument("--out", default=os.path.join(package, "results"), help="directory of bench_sim.json")
    args = parser.parse_args()
    started = time.monotonic()
    load_at_start = os.getloadavg()[0]

    core = run_core(args.map, args.robots)
    node = {}
    log("node: simulator at rtf 0 with a subscriber to every topic, %.0f s of sim time per run" % args.sim_seconds)
    with Roscore(), tempfile.TemporaryDirectory(prefix="bench_sim_") as workdir:
        for robots in args.robots:
            node[robots] = run_node(args.map, robots, core[robots]["start_poses"], args.sim_seconds, args.config,
                                    workdir)

    first, last = min(args.robots), max(args.robots)
    rows = []
    for robots in args.robots:
        c, n = core[robots], node[robots]
        rows.append({
            "robots": robots,
            "core_rtf_cpu": round(c["rtf_cpu"], 1),
            "core_rtf_wall": round(c["rtf"], 1),
            "node_rtf_wall": round(n["rtf"], 1),
            "node_rtf_cpu": round(n["rtf_cpu"], 1),
            "core_time_split": {"raycasting": round(c["raycast_share"], 3), "physics": round(c["physics_share"], 3)},
            "node_time_split": {"raycasting": round(n["simulate_share"] * c["raycast_share"], 3),
                                "physics": round(n["simulate_share"] * c["physics_share"], 3),
                                "publishing": round(n["publish_share"], 3),
                                "other": round(max(0.0, 1.0 - n["simulate_share"] - n["publish_share"]), 3)},
            "ns_per_ray": round(c["ns_per_ray"], 1),
            "node_messages_published": n["messages_published"],
            "node_messages_received_by_sink": n["messages_received_by_sink"],
        })
    ratio_key = "ratio_%d_to_%d_robots" % (first, last)
    reference = 4 if 4 in core else first
    headline = [
        {"figure": "core real-time factor, %d robots, per CPU second of one core" % reference,
         "value": round(core[reference]["rtf_cpu"], 1), "unit": "x", "goal": ">= 2000" if reference == 4 else ""},
        {"figure": "core real-time factor, %d robots, per wall second" % reference,
         "value": round(core[reference]["rtf"], 1), "unit": "x", "goal": ""},
        {"figure": "node real-time factor, %d robots, every topic subscribed, wall" % reference,
         "value": round(node[reference]["rtf"], 1), "unit": "x", "goal": ">= 300" if reference == 4 else ""},
        {"figure": "node real-time factor, %d robots, every topic subscribed, per CPU second" % reference,
         "value": round(node[reference]["rtf_cpu"], 1), "unit": "x", "goal": ""},
        {"figure": "core rtf %d robots / %d robots (CPU)" % (first, last),
         "value": round(core[first]["rtf_cpu"] / core[last]["rtf_cpu"], 2), "unit": "", "goal": ""},
        {"figure": "node rtf %d robots / %d robots (wall)" % (first, last),
         "value": round(node[first]["rtf"] / node[last]["rtf"], 2), "unit": "", "goal": ""},
        {"figure": "core time in ray casting, %d robots" % reference, "value": round(100 * core[reference]["raycast_share"], 1),
         "unit": "%", "goal": ""},
        {"figure": "node time publishing, %d robots" % reference, "value": round(100 * node[reference]["publish_share"], 1),
         "unit": "%", "goal": ""},
    ]
    result = {
        "headline": headline,
        "benchmark": "simulator real-time factor (sim seconds per wall second), lidar 5 Hz, physics 20 Hz, one arena",
        "map": os.path.relpath(args.map, package) if args.map.startswith(package) else args.map,
        # Other processes inflate wall-clock figures, hence the CPU-time ones and the load.
        "machine": {"cpus": os.cpu_count(), "processor": platform.processor() or platform.machine(),
                    "load_average_1min_at_start": round(load_at_start, 2),
                    "load_average_1min_at_end": round(os.getloadavg()[0], 2)},
        "goals": {"core_rtf_at_4_robots": 2000, "node_rtf_at_4_robots": 300},
        "rows": rows,
        ratio_key: {"core_cpu": round(core[first]["rtf_cpu"] / core[last]["rtf_cpu"], 2),
                    "node_wall": round(node[first]["rtf"] / node[last]["rtf"], 2)},
        "wall_seconds": round(time.monotonic() - started, 1),
    }
    os.makedirs(args.out, exist_ok=True)
    output = os.path.join(args.out, "bench_sim.json")
    write_result(Path(output), result)

    log("")
    log("robots | core rtf (CPU / wall) | node rtf (wall / CPU) | core: ray casting / physics | node: ray casting / physics / publishing")
    for row in rows:
        cs, ns = row["core_time_split"], row["node_time_split"]
        log("%6d | %8.0f / %8.0f     | %8.0f / %8.0f     | %12.0f%% / %3.0f%%         | %12.0f%% / %3.0f%% / %3.0f%%" % (
            row["robots"], row["core_rtf_cpu"], row["core_rtf_wall"], row["node_rtf_wall"], row["node_rtf_cpu"],
            100 * cs["raycasting"], 100 * cs["physics"], 100 * ns["raycasting"], 100 * ns["physics"],
            100 * ns["publishing"]))
    ratio = result[ratio_key]
    log("rtf ratio %d -> %d robots: core %.2f (CPU), node %.2f (wall)" % (first, last, ratio["core_cpu"], ratio["node_wall"]))
    log("written %s (%.0f s)" % (output, result["wall_seconds"]))
