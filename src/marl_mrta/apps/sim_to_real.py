"""`sim_to_real`: the paper's Table 10 (sim-to-real) against the hardware stand-in.

    rosrun marl_mrta sim_to_real [--policy ACTOR] [--scenario scenarios/lab_2r.xml] [--out results]

Runs one learned policy on the scenario three ways, one launch each on a private master: the
lock-step simulation (ideal), the simulation with the measured_tb3 noise profile, and
real.launch against the stand-in (wall time, amcl, decentralised actors). Reports each run's
makespan, allocation and logic consistency, amcl's localisation error against the stand-in's
ground truth file, the command-to-motion latency measured in the graph (cmd_vel against odom),
the episode's wall time; then the stop latency of real.launch per failure kind (a robot killed,
Ctrl-C, the e-stop, a move_base abort, the task manager hung: the cmd_vel gates' permit times
out, a robot mislocalised: amcl told it stands 1 m off, the ROS master lost). Writes
<out>/sim_to_real.json and <out>/sim_to_real.png (about 9 minutes). Without --policy a policy is trained first (embedded,
sequential preset, seconds). `sim_to_real probe --robots ... --out FILE` is the recording node
it starts in each launch.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List, Optional, Sequence

from marl_mrta.common.config import read_yaml
from marl_mrta.common.paths import default_config_path, package_root
from marl_mrta.common.results import write_result
from marl_mrta.evaluation.sim_to_real import (FAULTS, PAPER, ROBOTS, ROWS, displaced_position, plot,
                                              read_ground_truth, row_figures, stop_time)

MANAGER = "/rl_task_allocation_manager"
#: Where each failure kind's stop latency counts from (the fault known to the graph).
MEASURED_FROM = {"robot_killed": "tb3_1's first part silent for its limit after the SIGKILL of its stand-in",
                 "ctrl_c": "SIGINT to the task manager", "estop": "the ~estop call",
                 "move_base_abort": "tb3_0's move_base result ABORTED published",
                 "master_lost": "SIGKILL of the ROS master + master_lost_after (1.0 s): the master unanswered for its "
                                "limit",
                 "manager_hung": "SIGSTOP of the task manager + the cmd_vel gates' permit_timeout (1.0 s): its last "
                                 "permit too old",
                 "mislocalised": "the 10th scan_fit in a row (scan_fit_lost_scans) below scan_fit_min after tb3_0's "
                                 "amcl was told a pose 1 m from its estimate (2 cm spread)"}
#: How far from its estimate the mislocalisation fault tells amcl the robot stands [m].
DISPLACEMENT = 1.0
#: The scenario of the stop-latency runs.
FAULT_SCENARIO = package_root() / "scenarios" / "lab_2r.xml"


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="sim_to_real", description=__doc__.split("\n\n")[0])
    parser.add_argument("--policy", default=None, help="actor file (default: train one, sequential preset)")
    parser.add_argument("--mask", default="", help="the task manager's action mask for the policy (default: finished "
                        "for the policy trained here, sequential preset; logic, the tuned preset's, for --policy)")
    parser.add_argument("--scenario", default=str(package_root() / "scenarios" / "lab_2r.xml"), help="scenario XML")
    parser.add_argument("--out", default=str(package_root() / "results"), help="directory of the report (default results/)")
    parser.add_argument("--episodes", type=int, default=1, help="episodes of each of the three runs (default 1)")
    parser.add_argument("--port", type=int, default=11871, help="first private master port (default 11871)")
    parser.add_argument("--faults", default=",".join(FAULTS), help=f"failure kinds to time ({', '.join(FAULTS)})")
    args = parser.parse_args(list(argv))
    if args.episodes < 1:
        parser.error(f"--episodes: must be >= 1, got {args.episodes}")
    unknown = [f for f in args.faults.split(",") if f and f not in FAULTS]
    if unknown:
        parser.error(f"--faults: unknown {', '.join(unknown)} (choose from {', '.join(FAULTS)})")
    return args


# ---------------------------------------------------------------------- launches and the probe

def start_launch(args: List[str], log: Path, master_uri: Optional[str] = None, port: Optional[int] = None):
    env = dict(os.environ)
    if master_uri:
        env["ROS_MASTER_URI"] = master_uri
    command = ["roslaunch"] + (["-p", str(port)] if port else []) + ["marl_mrta"] + args
    return subprocess.Popen(command, stdout=open(log, "w"), stderr=subprocess.STDOUT, start_new_session=True, env=env)


def stop_group(process: subprocess.Popen, timeout: float = 30.0) -> None:
    from marl_mrta.ros.process_group import stop_process_group
    stop_process_group(process, timeout)


def wait_param(master_uri: str, name: str, timeout: float, process: subprocess.Popen) -> None:
    import rosgraph
    master = rosgraph.Master("/sim_to_real", master_uri=master_uri)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and process.poll() is None:
        try:
            if master.hasParam(name):
                return
        except OSError:
            pass
        time.sleep(0.5)
    raise RuntimeError(f"{name} did not appear on {master_uri} within {timeout:.0f} s")


def run_row(kind: str, launch_args: List[str], work: Path, port: int) -> Dict:
    """One run with the probe recording; its result document, the recordings, the ground truth."""
    uri = f"http://localhost:{port}"
    out, probe_file = work / f"{kind}.json", work / f"{kind}_probe.json"
    launch = start_launch(launch_args + [f"out:={out}"], work / f"{kind}.log", port=port)
    wait_param(uri, MANAGER + "/scenario", 120.0, launch)
    probe = subprocess.Popen([sys.executable, "-m", "marl_mrta.apps.sim_to_real", "probe", "--out", str(probe_file)],
                             env=dict(os.environ, ROS_MASTER_URI=uri), start_new_session=True)
    try:
        launch.wait(900.0)
    finally:
        stop_group(launch)
        os.killpg(probe.pid, signal.SIGINT)
        probe.wait(30.0)
    return {"result": json.loads(out.read_text()), "probe": json.loads(probe_file.read_text()),
            "ground_truth": read_ground_truth(work.glob(f"{kind}_gt/*.csv"))}


# ---------------------------------------------------------------------- stop latency per failure kind

def time_fault(kind: str, work: Path, master_uri: str, probe) -> Dict:
    import rosgraph
    import rosnode
    import rospy
    import xmlrpc.client
    from actionlib_msgs.msg import GoalStatus, GoalStatusArray
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from move_base_msgs.msg import MoveBaseActionResult
    from std_msgs.msg import Float32
    from std_srvs.srv import Trigger
    from marl_mrta.model.scenario import load_scenario
    from marl_mrta.ros.manager_settings import read_manager_settings
    from marl_mrta.ros.safety import SafetyMonitor

    def pid_of(name: str) -> int:
        uri = rosnode.get_api_uri(rosgraph.Master("/sim_to_real", master_uri=master_uri), name,
                                   skip_cache=True)   # each run's launch starts the node anew
        return xmlrpc.client.ServerProxy(uri).getPid("/sim_to_real")[2]

    args = ["real.launch", f"scenario:={FAULT_SCENARIO}", "stand_in:=true", "method:=exact", "episodes:=1", "go:=true",
            "nav:=builtin",
            f"out:={work / (kind + '.json')}", f"aborted_episode_file:={work / (kind + '_aborted.json')}"]
    if kind == "robot_killed":
        args.append("stand_in_processes:=per_robot")
    result_pub = rospy.Publisher("/tb3_0/move_base/result", MoveBaseActionResult, queue_size=1)
    launch = start_launch(args, work / f"{kind}.log", master_uri=master_uri)
    try:
        started = time.time()
        deadline = started + 300.0
        while not all(any(t > started and abs(v) > 0.05 for t, v, _ in probe.snapshot()[ns]["cmd_vel"]) for ns in ROBOTS):
            if time.time() > deadline or launch.poll() is not None:
                raise RuntimeError(f"{kind}: the robots did not start driving ({work / (kind + '.log')})")
            time.sleep(0.1)
        time.sleep(3.0)
        # The limits the manager runs with (its rosparams over config/task_manager.yaml).
        limits = read_manager_settings(rospy.get_param(MANAGER), MANAGER).real.limits
        killed = None
        if kind == "robot_killed":
            os.kill(pid_of("/tb3_1/turtlebot3_stand_in"), signal.SIGKILL)
            killed = known = time.time()   # known: below, from the robot's last messages
        elif kind == "ctrl_c":
            os.kill(pid_of(MANAGER), signal.SIGINT)
            known = time.time()
        elif kind == "estop":
            estop = rospy.ServiceProxy(MANAGER + "/estop", Trigger)
            known = time.time()
            estop()
        elif kind == "move_base_abort":
            status = rospy.wait_for_message("/tb3_0/move_base/status", GoalStatusArray, timeout=5.0)
            active = [s for s in status.status_list if s.status == GoalStatus.ACTIVE]
            message = MoveBaseActionResult()
            message.header.stamp = rospy.Time.now()
            message.status.goal_id = active[-1].goal_id
            message.status.status = GoalStatus.ABORTED
            message.status.text = "Failed to find a valid plan. Even after executing recovery behaviors."
            known = time.time()
            result_pub.publish(message)
        elif kind == "manager_hung":   # nothing of the manager's own stop runs: the gates' permit times out
            manager = pid_of(MANAGER)
            os.kill(manager, signal.SIGSTOP)
            killed = time.time()
            known = killed + read_yaml(default_config_path("cmd_vel_gate.yaml")).number("permit_timeout")
        elif kind == "mislocalised":   # known once the scan has fitted badly for its limit
            fits = []   # (wall time, fit) the manager published
            fit_topic = rospy.Subscriber("/tb3_0/scan_fit", Float32, lambda msg: fits.append((time.time(), msg.data)))
            # Not latched: the next kind's launch, on the same master, must not get this pose too.
            told = rospy.Publisher("/tb3_0/initialpose", PoseWithCovarianceStamped, queue_size=1)
            estimate = rospy.wait_for_message("/tb3_0/amcl_pose", PoseWithCovarianceStamped, timeout=5.0)
            wrong = PoseWithCovarianceStamped()
            wrong.header.frame_id, wrong.header.stamp = "map", rospy.Time.now()
            wrong.pose.pose.orientation = estimate.pose.pose.orientation
            p = estimate.pose.pose.position
            wrong.pose.pose.position.x, wrong.pose.pose.position.y = displaced_position(
                load_scenario(FAULT_SCENARIO).load_map(), p.x, p.y, DISPLACEMENT)
            wrong.pose.covariance = [0.02 ** 2 if i in (0, 7, 35) else 0.0 for i in range(36)]
            deadline = time.time() + 5.0
            while told.get_num_connections() == 0 and time.time() < deadline:
                time.sleep(0.05)
            told.publish(wrong)
            killed = time.time()
            time.sleep(0.5)
            told.unregister()
            known = killed + 0.2 * limits.scan_fit_lost_scans + 1.0   # a bound until the fits are counted below
        else:   # master_lost: known once the master has not answered for its limit (it answered at the kill)
            os.kill(master_process_pid(master_uri), signal.SIGKILL)
            killed = time.time()
            known = killed + limits.master_lost_after
        time.sleep(2.5 + max(0.0, known - time.time()))
        if kind == "manager_hung":   # let it go on: it finds its goals cancelled and ends the episode
            os.kill(manager, signal.SIGCONT)
        records = probe.snapshot()
        if kind == "mislocalised":   # known with the bad fit that made scan_fit_lost_scans in a row
            fit_topic.unregister()
            below = [t for t, fit in fits if t > killed and fit < limits.scan_fit_min]
            rule = SafetyMonitor(["tb3_0"], limits)   # the manager's rule, told the fits it published
            for t, fit in fits:
                if t > killed:
                    rule.fitted(0, fit, t)
                    if rule.fault(t):
                        known = t
                        break
            else:
                raise RuntimeError(f"{kind}: tb3_0's scan_fit was not below {limits.scan_fit_min} "
                                   f"{limits.scan_fit_lost_scans} times in a row ({len(below)} below)")
        if kind == "robot_killed":   # known once the first of its parts has been silent for its limit
            last = {part: max((r[0] for r in records["tb3_1"][part] if r[0] <= killed), default=killed)
                    for part in ("odom", "scan")}
            known = min(last["odom"] + limits.odom_silent_after, last["scan"] + limits.scan_silent_after)
        latency = {ns: (lambda s: None if s is None else s - known)(stop_time([tuple(r) for r in records[ns]["cmd_vel"]],
                                                                              known - 1.0)) for ns in ROBOTS}
    finally:
        stop_group(launch)
    aborted = work / (kind + "_aborted.json")
    reason = json.loads(aborted.read_text())["abort_reason"] if aborted.exists() else ""
    from_fault = {ns: None if v is None else v + known - killed for ns, v in latency.items()} if killed else latency
    return {"stop_latency_s": latency, "measured_from": MEASURED_FROM[kind], "reason": reason,
            "stop_after_fault_s": from_fault,   # detection included: from the kill
            "worst_s": max((v for v in latency.values() if v is not None), default=None)}


def master_process_pid(master_uri: str) -> int:
    import rosgraph
    return rosgraph.Master("/sim_to_real", master_uri=master_uri).getPid()


# ---------------------------------------------------------------------- the report

def report_main(args: argparse.Namespace) -> int:
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="sim_to_real_"))
    policy = args.policy
    if not policy:
        from marl_mrta.apps.train import main as train_main
        run_dir = work / "train"
        if train_main(["--scenario", args.scenario, "--preset", "sequential", "--seed", "0", "--out", str(run_dir)]) != 0:
            print("sim_to_real: training failed", file=sys.stderr)
            return 1
        policy = str(run_dir / "actor.pt")
    mask = args.mask or ("logic" if args.policy else "finished")
    common = [f"scenario:={args.scenario}", f"episodes:={args.episodes}", f"mask:={mask}"]
    plans = {"sim_ideal": ["evaluate.launch", "method:=policy", f"policy:={policy}"],
             "sim_measured": ["evaluate.launch", "method:=policy", f"policy:={policy}", "noise_profile:=measured_tb3"],
             "stand_in": ["real.launch", "stand_in:=true", "method:=policy", f"policy:={policy}", "go:=true",
                          "nav:=builtin", f"ground_truth_dir:={work / 'stand_in_gt'}"]}
    (work / "stand_in_gt").mkdir()
    rows = {}
    for k, (kind, launch_args) in enumerate(plans.items()):
        print(f"sim_to_real: {ROWS[kind]} ...", file=sys.stderr)
        rows[kind] = row_figures(kind, run_row(kind, launch_args[:1] + common + launch_args[1:], work, args.port + k))
    report = {"scenario": args.scenario, "policy": policy, "mask": mask, "rows": rows, "paper": PAPER,
              "paper_gap_pct": 100.0 * (PAPER["real"] / PAPER["simulation"] - 1.0),
              "stand_in_gap_pct": 100.0 * (rows["stand_in"]["makespan"] / rows["sim_ideal"]["makespan"] - 1.0),
              "measured_gap_pct": 100.0 * (rows["sim_measured"]["makespan"] / rows["sim_ideal"]["makespan"] - 1.0)}
    faults = [f for f in args.faults.split(",") if f]
    if faults:
        report["faults"] = run_faults(sorted(faults, key=FAULTS.index), work, args.port + len(plans))
    write_result(out_dir / "sim_to_real.json", report)
    plot(report, out_dir / "sim_to_real.png")
    for kind, row in rows.items():
        loc = row["localisation_error_m"]
        print(f"{row['label']}: makespan {row['makespan']:.2f} s, logic-consistent {row['logic_consistent_pct']:.0f} %, "
              f"allocation {row['allocation']}, command-to-motion median {row['command_to_motion_s']['median']}, "
              f"localisation mean {loc['mean']} m max {loc['max']} m")
    print(f"wrote {out_dir / 'sim_to_real.json'} and {out_dir / 'sim_to_real.png'} (runs in {work})", file=sys.stderr)
    failed = [kind for kind, result in report.get("faults", {}).items() if "error" in result]
    if failed:
        print(f"sim_to_real: no stop latency for {', '.join(failed)} (the report says why)", file=sys.stderr)
        return 1
    return 0


def run_faults(faults: Sequence[str], work: Path, port: int) -> Dict:
    """Each failure kind on one master the report starts (the master-lost run kills it: last)."""
    import rospy
    from marl_mrta.ros.graph_probe import GraphProbe
    uri = f"http://localhost:{port}"
    master = subprocess.Popen(["roscore", "-p", str(port)], stdout=open(work / "roscore.log", "w"),
                              stderr=subprocess.STDOUT, start_new_session=True)
    os.environ["ROS_MASTER_URI"] = uri
    time.sleep(3.0)
    rospy.init_node("sim_to_real", disable_signals=True)
    probe = GraphProbe(ROBOTS)
    results = {}
    try:
        for kind in faults:
            print(f"sim_to_real: stop latency, {kind} ...", file=sys.stderr)
            try:
                results[kind] = time_fault(kind, work, uri, probe)
            except Exception as error:   # noqa: BLE001 - one kind that fails must not cost the report
                results[kind] = {"error": f"{type(error).__name__}: {error}"}
                print(f"sim_to_real: stop latency, {kind}: failed: {results[kind]['error']} "
                      f"(its launch log: {work / (kind + '.log')})", file=sys.stderr)
            time.sleep(2.0)
    finally:
        stop_group(master)
    return results


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = [a for a in (sys.argv[1:] if argv is None else argv) if ":=" not in a]
    if argv and argv[0] == "probe":
        from marl_mrta.ros.graph_probe import main as probe_main
        return probe_main(argv[1:])
    return report_main(parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
