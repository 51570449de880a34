"""`scripts/bench_mappo --ros`: time to policy on the ros backend (lab_2r, ROS simulation).

Starts its own graph (`tasks.launch arenas:=K mask:=<the preset's action_mask> localization:=simulator`,
lock-step, as fast as possible, built-in navigation, on a private master port) and measures, against the exact plan's
makespan *in the same simulation* (its one episode run first; target = 1.05 × that):

- `pretrained`: the preset trains on the embedded backend (seed 0) until its greedy policy is
  within 5 % of the embedded exact optimum; the greedy policy is then evaluated in the K ROS
  arenas (one episode each). If it misses the ROS target, the next seed is trained and checked,
  up to `--pretrain-seeds` candidates (one whose embedded allocation already missed is skipped);
  if none passes, the best trains on on the ros backend from its checkpoint (networks,
  optimisers, normaliser), with a greedy evaluation in the arenas after every update. Time to
  policy = all embedded training + ROS evaluations and training (graph start-up excluded,
  reported apart).
- `scratch`: the preset (`--preset`, default tuned) on the ros backend alone (n_envs = K) with a greedy evaluation
  in the arenas after every update, until the target or `--ros-minutes`.
The results go into the `ros` section and the headline of <out>/bench_mappo.json; the
embedded figures there are kept.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional

from marl_mrta.baselines.reference import scenario_reference
from marl_mrta.common.results import write_result
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.evaluation.policies import PlanPolicy
from marl_mrta.evaluation.training import in_pool
from marl_mrta.mappo.config import MappoConfig
from marl_mrta.mappo.runner import Runner
from marl_mrta.ros.process_group import stop_process_group

WITHIN = 1.05


class GraphError(RuntimeError):
    """The ROS graph did not come up; str(error) is one line."""


class RosGraph:
    """tasks.launch with K arenas on a private master, stopped on exit."""

    def __init__(self, scenario: str, arenas: int, port: int, log_file: Path, mask: str):
        self.command = ["roslaunch", "-p", str(port), "marl_mrta", "tasks.launch", f"scenario:={scenario}",
                        f"arenas:={arenas}", f"mask:={mask}", "localization:=simulator"]  # as train.launch
        self.port = port
        self.log_file = log_file
        self.process: Optional[subprocess.Popen] = None

    def __enter__(self) -> "RosGraph":
        os.environ["ROS_MASTER_URI"] = f"http://localhost:{self.port}"
        self.log_file.parent.mkdir(parents=True, exist_ok=True)
        self._log = open(self.log_file, "w")
        self.process = subprocess.Popen(self.command, stdout=self._log, stderr=subprocess.STDOUT,
                                        start_new_session=True)
        # roslaunch starts its master first; the pool then waits for the managers themselves.
        import rosgraph
        deadline = time.monotonic() + 120.0
        while not rosgraph.is_master_online():
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.__exit__(None, None, None)
                raise GraphError(f"roslaunch did not bring up a master on port {self.port} (log: {self.log_file})")
            time.sleep(0.5)
        return self

    def __exit__(self, *exc) -> None:
        if self.process is not None:
            stop_process_group(self.process, 60.0)
        self._log.close()


def exact_in_ros(pool, scenario, log) -> Dict[str, Any]:
    """The exact plan's episode in arena 0 of the simulation (the reference of the target)."""
    client = pool.envs[0].env
    plan, instance = scenario_reference(scenario, client.settings.min_step)
    started = time.perf_counter()
    record = run_episodes(client, PlanPolicy(plan, client.n_agents, client.n_tasks), 1, 0)[0]
    log(f"exact plan in the ROS simulation: {record.makespan:.2f} s (nominal {plan.makespan:.2f} s), "
        f"{time.perf_counter() - started:.1f} s wall")
    return {"makespan_s": float(record.makespan), "nominal_makespan_s": plan.makespan,
            "complete": bool(record.complete), "robot_tasks": plan.describe(instance.task_ids)}


def _stop_after(runner: Runner, minutes: float) -> threading.Timer:
    timer = threading.Timer(minutes * 60.0, lambda: setattr(runner, "stop_requested", True))
    timer.daemon = True
    timer.start()
    return timer


def _ros_run(runner: Runner, minutes: float, log) -> Dict[str, Any]:
    timer = _stop_after(runner, minutes)
    try:
        summary = runner.run()
    finally:
        timer.cancel()
    evaluations = runner.history["evaluations"]
    return {"updates": summary.updates, "env_steps": summary.env_steps, "episodes": summary.episodes,
            "wall_s": round(summary.wall_time, 1), "time_to_policy_s": summary.time_to_target,
            "steps_to_policy": summary.steps_to_target,
            "greedy_makespans_s": [round(e["makespan"], 2) for e in evaluations],
            "steps_per_s": round(summary.env_steps / summary.wall_time, 3) if summary.wall_time else None,
            "actor": str(runner.actor_path)}


def _pretrained(tuned: MappoConfig, ros_config: MappoConfig, scenario_path: str, scenario_file: str, pool, seed: int,
                pretrain_seeds: int, runs: Path, embedded_target: float, target: float, minutes: float,
                train_embedded: Callable, log) -> Dict[str, Any]:
    """Embedded candidates (seeds seed, seed+1, ...) checked greedily in the ROS arenas in turn; the
    first within the target is the policy. The embedded executor does not model robots meeting, so
    allocations it scores alike can differ by seconds in ROS (docs/guide/training.md); a candidate whose
    embedded allocation already failed in ROS is not run again. If none passes, the best one trains
    on in ROS. Time to policy counts every embedded training and every ROS evaluation."""
    out = runs / "ros_pretrained"

    def ros_runner(actor: str) -> Runner:
        """A fresh ros-backend run in `out`, starting from the embedded run's checkpoint beside `actor`."""
        shutil.rmtree(out, ignore_errors=True)
        runner = Runner(ros_config, None, evaluate=in_pool(pool), scenario=scenario_file, seed=seed, out_dir=out,
                        log=log, target_makespan=target, stop_at_target=True, tensorboard=False, plots=False,
                        pool=pool)
        runner.trainer.load_state_dict(Runner.read_checkpoint(Path(actor).with_name("checkpoint.pt"))["trainer"])
        runner.start()
        return runner

    spent = 0.0
    candidates: List[Dict[str, Any]] = []
    failed_allocations: List[Any] = []
    best: Optional[Dict[str, Any]] = None
    for k in range(pretrain_seeds):
        embedded = train_embedded(replace(tuned, eval_every=1), scenario_path, seed + k, runs / f"ros_pretrain_s{seed + k}",
                                  embedded_target, True, log)
        spent += embedded["train_wall_s"]
        candidate: Dict[str, Any] = {"embedded": embedded}
        candidates.append(candidate)
        if embedded["time_to_policy_s"] is None:
            candidate["ros"] = "not run: the embedded target was not reached"
            continue
        if embedded["greedy_allocation"] in failed_allocations:
            candidate["ros"] = "not run: the same allocation already missed the target in ROS"
            log(f"  seed {seed + k}: allocation {embedded['greedy_allocation']} already missed in ROS; skipped")
            continue
        runner = ros_runner(embedded["actor"])
        first = runner.evaluate()
        candidate["ros"] = {"greedy_makespan_s": round(first["makespan"], 2), "wall_s": round(runner.wall_time, 1)}
        log(f"  seed {seed + k}: embedded actor greedy in ROS {first['makespan']:.2f} s ({first['wall_time']:.1f} s wall)")
        if runner.time_to_target is not None:
            runner.save_checkpoint()
            spent += runner.time_to_target
            return {"candidates": candidates, "chosen_seed": seed + k, "ros_training": None,
                    "actor": str(runner.actor_path), "time_to_policy_s": round(spent, 2)}
        spent += runner.wall_time
        failed_allocations.append(embedded["greedy_allocation"])
        if best is None or first["makespan"] < best["makespan"]:
            best = {"makespan": first["makespan"], "seed": seed + k, "actor": embedded["actor"]}
    if best is None:
        return {"candidates": candidates, "chosen_seed": None, "ros_training": None, "time_to_policy_s": None}
    log(f"  no candidate within the target; seed {best['seed']} ({best['makespan']:.2f} s) trains on in ROS")
    runner = ros_runner(best["actor"])
    ros_training = _ros_run(runner, minutes, log)
    reached = runner.time_to_target
    return {"candidates": candidates, "chosen_seed": best["seed"], "ros_training": ros_training,
            "actor": ros_training["actor"], "time_to_policy_s": None if reached is None else round(spent + reached, 2)}


def measure(tuned: MappoConfig, scenario_path: str, arenas: int, minutes: float, port: int, seed: int,
            runs: Path, embedded_target: float, train_embedded: Callable, modes: List[str], log, *,
            pretrain_seeds: int) -> Dict[str, Any]:
    from marl_mrta.ros.arena_pool import arena_pool

    ros_config = replace(tuned, n_envs=arenas, eval_every=1, eval_episodes=arenas)
    result: Dict[str, Any] = {"arenas": arenas, "criterion": f"greedy makespan in the ROS simulation <= {WITHIN} x "
                              "the exact plan's makespan in the same simulation", "seed": seed}
    with RosGraph(scenario_path, arenas, port, runs / "ros_graph.log", tuned.action_mask):
        started = time.perf_counter()
        from marl_mrta.ros.env_client import ManagerUnavailable
        from marl_mrta.mappo.runner import RunError
        try:
            pool, scenario_file = arena_pool(ros_config, seed, scenario_path, manager_wait=300.0)
        except (ManagerUnavailable, RunError) as error:
            raise GraphError(f"{error} (graph log: {runs / 'ros_graph.log'})") from None
        result["graph_startup_s"] = round(time.perf_counter() - started, 1)
        from marl_mrta.model.scenario import load_scenario
        exact = exact_in_ros(pool, load_scenario(scenario_file), log)
        target = WITHIN * exact["makespan_s"]
        result["exact_in_ros"] = exact
        result["target_s"] = round(target, 3)

        if "pretrained" in modes:
            log(f"pretrained: embedded training of up to {pretrain_seeds} seeds to {embedded_target:.2f} s, each "
                f"checked in the ROS arenas (target {target:.2f} s)")
            result["pretrained"] = _pretrained(tuned, ros_config, scenario_path, scenario_file, pool, seed, pretrain_seeds,
                                               runs, embedded_target, target, minutes, train_embedded, log)
            result["pretrained"]["target_s"] = result["target_s"]
            log(f"  pretrained: time to policy {result['pretrained']['time_to_policy_s']} s")

        if "scratch" in modes:
            log(f"scratch: {ros_config.decision_order} decisions, batch {ros_config.batch_size}, on {arenas} ROS arenas, at most {minutes:g} min (target {target:.2f} s)")
            out = runs / "ros_scratch"
            shutil.rmtree(out, ignore_errors=True)
            runner = Runner(ros_config, None, evaluate=in_pool(pool), scenario=scenario_file, seed=seed, out_dir=out,
                            log=log, target_makespan=target, stop_at_target=True, tensorboard=False, plots=False,
                            pool=pool)
            runner.start()
            scratch = _ros_run(runner, minutes, log)
            scratch["cap_minutes"] = minutes
            scratch["target_s"] = result["target_s"]
            result["scratch"] = scratch
            log(f"  scratch: time to policy {scratch['time_to_policy_s']} s after {scratch['env_steps']} steps "
                f"({scratch['steps_per_s']} steps/s); greedy {scratch['greedy_makespans_s']}")
        pool.close()
    return result


def merge_into(path: Path, ros: Dict[str, Any]) -> Dict[str, Any]:
    """bench_mappo.json with its `ros` section and ros headline rows replaced, the rest kept."""
    document = json.loads(path.read_text()) if path.exists() else {"headline": []}
    for mode in ("pretrained", "scratch"):   # a mode not run this time keeps its last result (and its own target)
        if mode not in ros and mode in document.get("ros", {}):
            ros[mode] = document["ros"][mode]
    document["ros"] = ros
    rows = [row for row in document.get("headline", []) if "ros" not in row["figure"]]
    pretrained = ros.get("pretrained", {})
    if pretrained:
        rows.append({"figure": f"time to policy, ros backend, lab_2r (embedded candidates checked in {ros['arenas']} ROS arenas, "
                               "trained on there if none passes)",
                     "value": pretrained.get("time_to_policy_s"), "unit": "s", "goal": "<= 600"})
    scratch = ros.get("scratch")
    if scratch:
        reached = scratch.get("time_to_policy_s")
        rows.append({"figure": f"time to policy, ros backend from scratch, lab_2r ({ros['arenas']} arenas, "
                               f"cap {scratch['cap_minutes']:g} min)",
                     "value": round(reached, 1) if reached is not None else f"> {scratch['cap_minutes'] * 60:.0f}",
                     "unit": "s", "goal": "<= 600"})
        rows.append({"figure": f"ros backend training throughput ({ros['arenas']} arenas)",
                     "value": scratch.get("steps_per_s"), "unit": "steps/s", "goal": ""})
    rows.append({"figure": "exact plan makespan in the ros simulation (reference of the ros target)",
                 "value": round(ros["exact_in_ros"]["makespan_s"], 2), "unit": "s", "goal": ""})
    document["headline"] = rows
    write_result(path, document, keeps_earlier=True)
    return document
