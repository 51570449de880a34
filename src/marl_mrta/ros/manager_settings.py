"""Parameters of rl_task_allocation_manager, read once and strictly (ROS-free, so pytest checks them).

Defaults come from config/task_manager.yaml; the node's private parameters override them. A
missing scenario, an unknown name, a wrong type or a value out of range is one line naming
the parameter.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, Optional

from marl_mrta.env.settings import DECISION_MODES, MASK_MODES
from marl_mrta.model.goal_timeout import TimeoutValue, check_goal_timeout
from marl_mrta.common.config import ConfigError, node_parameters, read_yaml
from marl_mrta.common.paths import default_config_path
from marl_mrta.ros.safety import SafetyLimits

#: How the robots are localised: from ground truth (nothing to do on a reset) or by amcl (told the
#: reset poses through initialpose).
LOCALIZATIONS = ("ground_truth", "amcl")
#: Private parameters the node writes itself for its clients; never read as settings.
OUTPUT_PARAMETERS = ("env",)
#: Robots whose controllers simulator_lost_after is meant for (RosExecutorSettings.lost_after).
ROBOTS_PER_LOST_AFTER = 4
#: What the robots are: the simulator (lock-step, teleporting resets) or real robots (wall time,
#: resets by driving, the operator's go, safe stops; ros/real_executor.py).
MODES = ("simulation", "real")
#: Real mode: where an episode starts: the scenario's start poses (driven to) or where the robots stand.
RESETS = ("start", "current")
#: Real mode, reset start: the robots drive back one at a time (model/fleet.py) or all at once.
RESET_DRIVES = ("one_by_one", "together")
#: Who decides: a client over ~step (rl_manager, evaluate, train) or the manager itself with the
#: replanning allocator (baselines/replan.py), which runs its episodes and takes run-time requests.
ALLOCATORS = ("client", "replan")
#: A fault that concerns one robot (real: its odometry, scan or move_base silent, its localisation
#: lost, a goal move_base aborted; simulation: its move_base gone): every robot stopped and the
#: episode aborted, or that robot alone stopped and out of the fleet while the others go on.
ROBOT_FAULTS = ("stop_fleet", "continue")


@dataclass(frozen=True)
class RosExecutorSettings:
    """How the executor reaches the graph (rosparams of rl_task_allocation_manager)."""

    robot_prefix: str = ""              # "" or "arena_k/": namespace prefix of this arena's robots
    arena: int = 0                      # arena index in the simulator
    simulator_lost_after: float = 3.0   # s of wall time without an answer -> episode aborted (per ROBOTS_PER_LOST_AFTER)
    graph_wait: float = 60.0            # s of wall time to wait for the simulator and move_base at start
    cancel_wait: float = 15.0           # s (sim time; real mode: wall) for a cancelled goal to end: stock
                                        # move_base ends it only between recovery behaviours
    align_period: float = 1.0           # s of sim time: steps start on multiples of it (0: no alignment)
    advance_in_lockstep: bool = False   # the paused simulator runs ticks through its lock-step instead of stepping them at once
    map_frame: str = "map"
    localization: str = "ground_truth"  # ground_truth (the simulator, fake_localization) | amcl: re-initialised on reset
    localization_wait: float = 10.0     # s of sim time for amcl_pose to agree with a reset pose
    localization_settle: float = 0.6    # s of sim time run after it agrees (amcl's transform_tolerance 0.5)
    localization_tolerance_xy: float = 0.10    # m
    localization_tolerance_yaw: float = 0.10   # rad
    on_robot_fault: str = "stop_fleet"  # stop_fleet | continue (ROBOT_FAULTS)

    def lost_after(self, n_robots: int) -> float:
        """s of wall time without an answer before the simulator counts as lost, for a team of
        n_robots: simulator_lost_after covers ROBOTS_PER_LOST_AFTER robots and grows with the
        team, because a tick waits for every robot's controller on the same CPUs."""
        return self.simulator_lost_after * max(1.0, n_robots / ROBOTS_PER_LOST_AFTER)


@dataclass(frozen=True)
class RealRobotSettings:
    """Real mode only (docs/guide/real_robots.md): resets, the operator's go, safe stops."""

    reset: str = "start"                # start: drive to the scenario's start poses | current: start where they stand
    go: bool = False                    # start each episode without the operator's ~go (unattended)
    limits: SafetyLimits = SafetyLimits()   # silences and master loss that stop the fleet
    reset_drive: str = "one_by_one"     # reset start: one robot at a time (model/fleet.py) | together
    reset_timeout: float = 120.0        # s of wall time for each drive of the reset to reach its start poses
    stop_hold: float = 1.0              # s of wall time a stop keeps sending zero cmd_vel (10 Hz)
    aborted_episode_file: str = ""      # JSON file for an aborted episode's record ("": none)


#: hold_successors as a parameter: a launch file's true/false, or empty for config/task.yaml's.
HOLD_CHOICES = {"": None, "true": True, "false": False}


@dataclass(frozen=True)
class LiveFleetSettings:
    """Who allocates, and with allocator replan the manager's own episodes (docs/guide/live_fleet.md)."""

    allocator: str = "client"           # client (~step) | replan (the manager decides itself)
    episodes: int = 1                   # replan: episodes the manager runs (episode k reset with seed + k)
    seed: int = 0                       # replan: seed of the first episode
    out: str = ""                       # replan: result document ("": results/runs/replan_ros_<scenario>.json)
    end_when_done: bool = False         # replan: the node exits after its episodes (ending a launch that requires it)
    request_wait: float = 30.0          # s of wall time a run-time request waits for a decision instant


@dataclass(frozen=True)
class ManagerSettings:
    scenario: str                  # scenario XML file
    mask: Optional[str]            # none | finished | logic; None: config/task.yaml
    task_config: Optional[str]     # decision-process settings file; None: config/task.yaml
    reward_config: Optional[str]   # reward file; None: config/reward.yaml
    marker_period: float           # s of wall time between marker refreshes while robots drive; 0: on changes only
    executor: RosExecutorSettings
    mode: str = "simulation"       # simulation | real
    real: RealRobotSettings = RealRobotSettings()
    hold_successors: Optional[bool] = None   # None: config/task.yaml's (model/rules.py)
    decision_mode: Optional[str] = None      # synchronous | event; None: config/task.yaml's
    goal_timeout: Optional[TimeoutValue] = None   # s or "auto"; None: the scenario's, else config/task.yaml's
    live: LiveFleetSettings = LiveFleetSettings()


def read_manager_settings(params: Dict[str, Any], namespace: str,
                          defaults_file: Optional[Path] = None) -> ManagerSettings:
    """`params`: the node's private parameters; `namespace`: its name, e.g. /rl_task_allocation_manager."""
    if params.get("scenario") in ("", None):
        raise ConfigError(f"{namespace}/scenario: missing: give the scenario XML file "
                          f"(roslaunch marl_mrta task_manager.launch scenario:=...)")
    values = dict(read_yaml(defaults_file or default_config_path("task_manager.yaml")).data)
    values.update({k: v for k, v in params.items() if k not in OUTPUT_PARAMETERS})
    if isinstance(values.get("hold_successors"), bool):   # a launch file's true/false arrives as a bool
        values["hold_successors"] = str(values["hold_successors"]).lower()
    p = node_parameters(values, namespace)
    scenario = p.string("scenario", allow_empty=False)
    mask = p.string("mask")
    if mask and mask not in MASK_MODES:
        raise p.fail("mask", f"{mask!r} is not one of {', '.join(MASK_MODES)} (or empty: config/task.yaml)")
    prefix = p.string("robot_prefix")
    if prefix and (not prefix.endswith("/") or prefix.startswith("/")):
        raise p.fail("robot_prefix", f"{prefix!r} must be empty or a relative namespace ending in '/' (arena_1/)")
    executor = RosExecutorSettings(
        robot_prefix=prefix, arena=p.integer("arena", minimum=0),
        simulator_lost_after=p.number("simulator_lost_after", above=0.0),
        graph_wait=p.number("graph_wait", above=0.0),
        cancel_wait=p.number("cancel_wait", above=0.0),
        align_period=p.number("align_period", minimum=0.0),
        advance_in_lockstep=p.boolean("advance_in_lockstep"),
        map_frame=p.string("map_frame", allow_empty=False),
        localization=p.choice("localization", LOCALIZATIONS),
        localization_wait=p.number("localization_wait", above=0.0),
        localization_settle=p.number("localization_settle", minimum=0.0),
        localization_tolerance_xy=p.number("localization_tolerance_xy", above=0.0),
        localization_tolerance_yaw=p.number("localization_tolerance_yaw", above=0.0),
        on_robot_fault=p.choice("on_robot_fault", ROBOT_FAULTS))
    mode = p.choice("mode", MODES)
    if mode == "real" and executor.localization != "amcl":
        raise p.fail("localization", f"must be amcl in real mode (real robots have no ground truth), got "
                                     f"{executor.localization!r}")
    limits = SafetyLimits(odom_silent_after=p.number("odom_silent_after", above=0.0),
                          scan_silent_after=p.number("scan_silent_after", above=0.0),
                          move_base_silent_after=p.number("move_base_silent_after", above=0.0),
                          master_lost_after=p.number("master_lost_after", above=0.0),
                          scan_fit_min=p.number("scan_fit_min", minimum=0.0, maximum=1.0),
                          scan_fit_lost_scans=p.integer("scan_fit_lost_scans", minimum=1),
                          scan_fit_tolerance=p.number("scan_fit_tolerance", above=0.0),
                          scan_fit_max_turn=p.number("scan_fit_max_turn", above=0.0))
    real = RealRobotSettings(reset=p.choice("reset", RESETS), go=p.boolean("go"), limits=limits,
                             reset_drive=p.choice("reset_drive", RESET_DRIVES),
                             reset_timeout=p.number("reset_timeout", above=0.0),
                             stop_hold=p.number("stop_hold", minimum=0.0),
                             aborted_episode_file=p.string("aborted_episode_file"))
    hold = p.string("hold_successors")
    if hold not in HOLD_CHOICES:
        raise p.fail("hold_successors", f"{hold!r}: expected true, false or empty (config/task.yaml's)")
    decision_mode = p.string("decision_mode")
    if decision_mode and decision_mode not in DECISION_MODES:
        raise p.fail("decision_mode", f"{decision_mode!r} is not one of {', '.join(DECISION_MODES)} "
                                      f"(or empty: config/task.yaml's)")
    live = LiveFleetSettings(allocator=p.choice("allocator", ALLOCATORS), episodes=p.integer("episodes", minimum=1),
                             seed=p.integer("seed", minimum=0), out=p.string("out"),
                             end_when_done=p.boolean("end_when_done"),
                             request_wait=p.number("request_wait", above=0.0))
    if live.allocator == "replan":   # the replanning allocator decides on events
        if decision_mode == "synchronous":
            raise p.fail("decision_mode", "synchronous: allocator replan decides in event mode (set decision_mode "
                                          "event, or leave it empty)")
        decision_mode = "event"
    goal_timeout = p.raw("goal_timeout")   # a launch file's "90" arrives as a string, a YAML 90 as a number
    try:
        goal_timeout = check_goal_timeout(goal_timeout, p.location("goal_timeout"))
    except ConfigError as error:
        raise ConfigError(f"{error} (or empty: the scenario's, else config/task.yaml's)") from None
    settings = ManagerSettings(scenario=scenario, mask=mask or None, task_config=p.string("task_config") or None,
                               reward_config=p.string("reward_config") or None,
                               marker_period=p.number("marker_period", minimum=0.0), executor=executor,
                               mode=mode, real=real,
                               hold_successors=HOLD_CHOICES[hold], decision_mode=decision_mode or None,
                               goal_timeout=goal_timeout, live=live)
    p.check_all_used(known=[k for k in values if k in p.used])
    return settings
