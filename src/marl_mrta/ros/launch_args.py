"""Values launch files take from a scenario or the simulator's parameter file, so that the
simulator runs the scenario's map and robots at its start poses and every robot's localisation
starts there (called from a launch file's $(eval)).

A scenario that cannot be loaded gives values that start a valid graph (the lab, one robot):
the task manager then reports the scenario's problem in its one-line FATAL and ends the launch.
"""
from __future__ import annotations

from typing import Optional, Sequence, Union

from marl_mrta.common.actor_settings import actor_path, read_actor_settings
from marl_mrta.common.config import ConfigError, read_yaml
from marl_mrta.common.paths import default_config_path, package_root
from marl_mrta.common.robot_names import name_list
from marl_mrta.model.scenario import ScenarioError, load_scenario



def scenario_value(path: str, key: str) -> Union[int, str]:
    """key: `robots` (count), `robot_names` (the robots' ids, their namespaces, separated by spaces),
    `map` (map_server YAML), `start_poses` (YAML list of [x, y, yaw]), `navigation` (the directory of
    the robots' navigation parameter files)."""
    default_navigation = str(default_config_path("nav"))
    try:
        scenario = load_scenario(path)
    except ScenarioError:
        fallback = {"robots": 1, "robot_names": "", "map": str(package_root() / "maps" / "lab.yaml"),
                    "start_poses": "[[0.5, 0.5, 0.0]]", "navigation": default_navigation}
        return fallback[key]
    if key == "robots":
        return scenario.n_robots
    if key == "robot_names":
        return " ".join(robot.id for robot in scenario.robots)
    if key == "map":
        return str(scenario.map_path.resolve())
    if key == "start_poses":
        return pose_list([(r.start.x, r.start.y, r.start.yaw) for r in scenario.robots])
    if key == "navigation":
        return str(scenario.navigation_dir) if scenario.navigation_dir else default_navigation
    raise KeyError(f"scenario_value: unknown key {key!r} (robots, robot_names, map, start_poses, navigation)")


def choice_timeout(path: str, lookahead: bool) -> int:
    """Wall s rl_manager waits for a robot's choice (execute.launch, real.launch): 30 for the actor
    alone; with lookahead 120 + 90 per robot. The first step waits for every node's opening
    rollout plan, and the nodes, one per robot, make theirs at once on the machine's cores: on 2
    cores site_8r's eight took 6.6 min, more than the 300 s this wait once was."""
    return 120 + 90 * int(scenario_value(path, "robots")) if lookahead else 30


def pose_list(poses: Sequence[Sequence[float]]) -> str:
    """Poses as the YAML (and Python) list launch files pass on: [[x, y, yaw], ...]."""
    return "[" + ", ".join(f"[{float(x)!r}, {float(y)!r}, {float(yaw)!r}]" for x, y, yaw in poses) + "]"


def config_start_poses(path: str) -> str:
    """`start_poses` of a simulator parameter file (config/sim.yaml); the lab's first pose when
    the file cannot be read (the simulator then reports the file's problem itself)."""
    try:
        poses = read_yaml(path).raw("start_poses")
        return pose_list(poses)
    except (ConfigError, TypeError, ValueError):
        return "[[0.5, 0.5, 0.0]]"


#: A fleet file's keys per robot (config/fleet_example.yaml): how roslaunch reaches it over SSH.
FLEET_DEFAULTS = {"ssh_port": 22, "timeout": 10.0}


def read_fleet(path: str) -> dict:
    """The fleet file: robot namespace -> {address, user, env_loader, ssh_port, timeout}; strict
    (an unknown or missing key is a ConfigError naming the file and key)."""
    fleet = read_yaml(path)
    machines = {}
    for robot in fleet.keys():
        entry = fleet.section(robot)
        machines[robot] = {"address": entry.string("address", allow_empty=False),
                           "user": entry.string("user", allow_empty=False),
                           "env_loader": entry.string("env_loader", allow_empty=False),
                           "ssh_port": entry.integer("ssh_port", FLEET_DEFAULTS["ssh_port"], minimum=1, maximum=65535),
                           "timeout": entry.number("timeout", FLEET_DEFAULTS["timeout"], above=0.0)}
    fleet.check_all_used()
    return machines


def fleet_value(path: str, robot: str, key: str) -> str:
    """One value of a robot's machine in the fleet file (launch/include/real_robot.launch's
    <machine> tag); a ValueError with one line when the file or the robot's entry is bad."""
    try:
        machines = read_fleet(path)
    except ConfigError as error:
        raise ValueError(f"fleet: {error}") from None
    if robot not in machines:
        raise ValueError(f"fleet: {path}: no entry for robot {robot} (it has {', '.join(machines) or 'none'})")
    return str(machines[robot][key])


def real_robots(robots: str, scenario: str) -> str:
    """real.launch's `robots` checked against the scenario's robots (the task manager drives the
    scenario's robot ids as namespaces): the names, space-separated (the scenario's when `robots`
    is empty); a ValueError if they differ."""
    names = name_list(robots)
    try:
        ids = [robot.id for robot in load_scenario(scenario).robots]
    except ScenarioError:
        return " ".join(names) or "tb3_0"   # the task manager reports the scenario's problem itself
    if not names:
        return " ".join(ids)
    if names != ids:
        raise ValueError(f"real.launch: robots:='{' '.join(names)}' are not the robots of {scenario} "
                         f"({' '.join(ids)}): give robots:='{' '.join(ids)}' or a scenario of these robots")
    return " ".join(names)


#: real.launch's arguments that take one of a few values (method: policy, or evaluate's methods).
REAL_CHOICES = {"method": ("policy", "exact", "ga", "auction", "random", "rollout"),
                "stand_in_processes": ("one", "per_robot"), "nav": ("auto", "builtin", "stock"),
                "reset": ("start", "current"), "reset_drive": ("one_by_one", "together")}


def noise_profiles() -> tuple:
    """The simulator's noise profiles (config/noise_profiles.yaml); ideal alone if it cannot be read
    (the simulator then reports the file itself)."""
    try:
        return tuple(read_yaml(str(package_root() / "config" / "noise_profiles.yaml")).keys())
    except ConfigError:
        return ("ideal",)


def real_choices(policy: Optional[str] = None, **values: str) -> bool:
    """real.launch's choice arguments checked: True, or a ValueError in one line naming the first bad one.
    With `policy` given, a method that acts from an actor (policy, rollout) also needs it non-empty,
    so that the launch stops before it starts anything."""
    choices = dict(REAL_CHOICES, noise_profile=noise_profiles())
    for name, value in values.items():
        parts = [value] if name != "method" or value == "policy" else value.split(",")
        if not value or any(part not in choices[name] or (name == "method" and len(parts) > 1 and part == "policy")
                            for part in parts):
            raise ValueError(f"real.launch: {name}:='{value}': must be one of {', '.join(choices[name])}")
    acting = sorted({"policy", "rollout"} & set(values.get("method", "").split(",")))
    if policy is not None and not policy.strip() and acting:
        raise ValueError(f"real.launch: policy:='': method:={acting[0]} needs an actor file: policy:=generalist "
                         f"(the shipped one) or the absolute path of a training run's actor.pt")
    return True


def policy_mask(policy: str, method: str = "policy") -> str:
    """The task manager's action masks for running `policy` (a path or a shipped name): the ones it
    was trained with, read from its file without torch. Without a policy (a planner), or for a file
    that cannot be read (rl_manager then says why in one line), `logic`, the tuned preset's."""
    if method not in ("policy", "lookahead") or not str(policy).strip():
        return "logic"
    try:
        return str(read_actor_settings(actor_path(policy, package_root())).get("action_mask", "none"))
    except ValueError:
        return "logic"
