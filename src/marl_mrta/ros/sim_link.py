"""The simulator as the ROS executor uses it (docs/reference/nodes_sim_nav.md): pause, step, reset, the
lock-step answers of the robots' controllers, ground truth and collision events.

Every service call is bounded in wall time, so a simulator that is gone or hangs raises
SimulatorLost instead of blocking the task manager.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence, Set, Tuple

import rospy
from geometry_msgs.msg import Pose2D as Pose2DMsg
from nav_msgs.msg import Odometry
from std_srvs.srv import SetBool

from marl_mrta.common.robot_names import arena_namespaces, default_robot_names, name_list
from marl_mrta.msg import CollisionEvent, LockstepAck
from marl_mrta.srv import ResetSim, ResetSimRequest, RunSim, StepSim

from marl_mrta.ros.sim_clock import SimulatorLost, call_bounded, wait_wall

SIMULATOR = "/simulator"
#: next_stamp of the answer made for a controller that is gone: the simulator need not wait for it
#: before this (2^31 - 1 s, the end of ROS time).
NEVER = rospy.Time(2 ** 31 - 1)


def quaternion_to_yaw(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


@dataclass(frozen=True)
class SimulatorConfig:
    """What the executor needs to know of the running simulator (its private parameters)."""

    physics_rate: float
    lockstep: bool
    lockstep_robots: Tuple[str, ...]   # empty: every robot
    robots: int                        # per arena
    arenas: int
    names: Tuple[str, ...] = ()        # of an arena's robots; empty: tb3_0 ...

    def robot_names(self) -> List[str]:
        """Namespaces of every simulated robot (common/robot_names.py)."""
        return arena_namespaces(self.names or default_robot_names(self.robots), self.arenas)

    def answers_lockstep(self, robot: str) -> bool:
        return self.lockstep and (not self.lockstep_robots or robot in self.lockstep_robots)


def read_simulator_config() -> SimulatorConfig:
    """The simulator's parameters; raises SimulatorLost when it has not published them."""
    try:
        params = rospy.get_param(SIMULATOR)
    except KeyError:
        raise SimulatorLost(f"no parameters under {SIMULATOR}: is the simulator running?") from None
    return SimulatorConfig(physics_rate=float(params.get("physics_rate", 20.0)),
                           lockstep=bool(params.get("lockstep", False)),
                           lockstep_robots=tuple(name_list(params.get("lockstep_robots"))),
                           robots=int(params.get("robots", 2)), arenas=int(params.get("arenas", 1)),
                           names=tuple(name_list(params.get("robot_names"))))


class SimulatorLink:
    """Services and state of the simulator for the robots of one arena (namespaces `robots`)."""

    def __init__(self, robots: Sequence[str], arena: int, answer_wall: float):
        self.robots = list(robots)
        self.arena = arena
        self.answer_wall = answer_wall
        self.config: Optional[SimulatorConfig] = None
        self._index = {ns: i for i, ns in enumerate(self.robots)}
        self._lock = threading.Lock()
        self._truth: List[Optional[Tuple[float, Tuple[float, float, float]]]] = [None] * len(self.robots)
        self._acked = [-1] * len(self.robots)
        self._goal_end = [0] * len(self.robots)   # LockstepAck.goal_end_tick, the latest answer's
        self._collisions: List[Tuple[float, int]] = []   # (sim time, robot index)
        self._released: Set[int] = set()   # robots whose controller is gone: no answer waited for
        self._ack_pub: Optional[rospy.Publisher] = None
        #: Asked when a wait for the controllers' answers runs out (RosExecutor: a controller that
        #: is gone released, on_robot_fault continue); True: the wait goes on.
        self.on_stall: Optional[Callable[[], bool]] = None
        self._reset = rospy.ServiceProxy(SIMULATOR + "/reset", ResetSim)
        self._pause = rospy.ServiceProxy(SIMULATOR + "/pause", SetBool)
        self._step = rospy.ServiceProxy(SIMULATOR + "/step", StepSim)
        self._run_until = rospy.ServiceProxy(SIMULATOR + "/run_until", RunSim)
        for i, ns in enumerate(self.robots):
            rospy.Subscriber("/" + ns + "/base_pose_ground_truth", Odometry, self._on_truth, i, queue_size=5,
                             tcp_nodelay=True)
        rospy.Subscriber(SIMULATOR + "/collisions", CollisionEvent, self._on_collision, queue_size=100)

    # ------------------------------------------------------------------ start-up

    def wait_ready(self, timeout_wall: float) -> SimulatorConfig:
        """Waits for the simulator's services; checks that it simulates this arena's robots."""
        for proxy in (self._reset, self._pause, self._step, self._run_until):
            try:
                proxy.wait_for_service(timeout=timeout_wall)
            except rospy.ROSException:
                raise SimulatorLost(f"service {proxy.resolved_name} is not available after "
                                    f"{timeout_wall:.0f} s: is the simulator running?") from None
        config = read_simulator_config()
        if config.robots != len(self.robots):
            raise SimulatorLost(f"the simulator runs {config.robots} robots per arena, the scenario has "
                                f"{len(self.robots)} (start the simulator with robots:={len(self.robots)})")
        known = config.robot_names()
        unknown = [ns for ns in self.robots if ns not in known]
        if unknown:
            raise SimulatorLost(f"the simulator has no robot {', '.join(unknown)} (it simulates {', '.join(known)}; "
                                f"its `robot_names` must be the scenario's robot ids: tasks.launch passes them)")
        self.config = config
        if self.tracks_answers:
            rospy.Subscriber(SIMULATOR + "/lockstep_ack", LockstepAck, self._on_ack, queue_size=100,
                             tcp_nodelay=True)
            # Made at start: release() must reach the simulator at once.
            self._ack_pub = rospy.Publisher(SIMULATOR + "/lockstep_ack", LockstepAck, queue_size=10, tcp_nodelay=True)
        return config

    @property
    def tracks_answers(self) -> bool:
        """Whether this link follows the controllers' lock-step answers. With one arena it must:
        the clock is paused, and a step may start only once every controller has seen the tick.
        With several arenas the clock runs on, and the simulator steps past tick T only once every
        controller has answered it (or said it needs nothing before a later tick), so /clock one
        tick later says the same; the answers, every robot's of every arena at every tick, would
        only cost this node time."""
        return self.config is not None and self.config.arenas == 1

    @property
    def _answers_from_clock(self) -> bool:
        """Lock-step with several arenas: /clock stands for the answers (tracks_answers)."""
        return self.config is not None and self.config.lockstep and not self.tracks_answers

    # ------------------------------------------------------------------ services

    def pause(self, paused: bool = True) -> None:
        response = call_bounded(lambda: self._pause(paused), self.answer_wall,
                                f"{SIMULATOR}/pause {str(paused).lower()}")
        if not response.success:
            raise SimulatorLost(f"{SIMULATOR}/pause refused: {response.message}")

    def step(self, ticks: int = 0, timeout_wall: Optional[float] = None) -> Tuple[int, float]:
        """Advances a paused simulator by `ticks` (0: none); returns (tick, sim time) reached."""
        response = call_bounded(lambda: self._step(ticks), timeout_wall or self.answer_wall,
                                f"{SIMULATOR}/step {ticks}")
        return int(response.tick), response.stamp.to_sec()

    def run_until(self, tick: int, goals_end_of: Sequence[str] = (), align_ticks: int = 0,
                  first_goal_end: bool = False) -> None:
        """Resumes a paused simulator, which pauses again by itself once `tick` is published, or
        earlier: on the first multiple of `align_ticks` at or after the tick on which the last of
        the robots `goals_end_of` ended a goal (their lock-step controllers report it), or with
        `first_goal_end` the first of them (event mode)."""
        call_bounded(lambda: self._run_until(until_tick=tick, until_goals_end_of=list(goals_end_of),
                                             align_ticks=align_ticks, until_first_goal_end=first_goal_end),
                     self.answer_wall, f"{SIMULATOR}/run_until {tick}")

    def release(self, robot: int) -> None:
        """The robot's lock-step controller is gone: the simulator is answered for it once, with an
        answer that needs no tick before the end of time (as stock_lockstep answers for a controller
        that cannot), and has_state() no longer waits for it. A controller that comes back answers
        again itself (its answers replace this one); watch_again() then waits for it again."""
        with self._lock:
            self._released.add(robot)
        tick, _ = self.step(0)
        if self._ack_pub is not None:
            self._ack_pub.publish(LockstepAck(robot=self.robots[robot], tick=tick, cmd_vel_count=0, next_stamp=NEVER,
                                              goal_end_tick=0))

    def watch_again(self, robot: Optional[int] = None) -> None:
        """Waits for the robot's (None: every robot's) answers again."""
        with self._lock:
            if robot is None:
                self._released.clear()
            else:
                self._released.discard(robot)

    def silent_controllers(self, tick: int) -> List[int]:
        """Robots whose lock-step controller has not answered `tick` (released ones aside)."""
        config = self.config
        with self._lock:
            return [i for i, ns in enumerate(self.robots) if self.tracks_answers and config.answers_lockstep(ns)
                    and i not in self._released and self._acked[i] < tick]

    def reset(self, poses: Sequence[Tuple[float, float, float]], seed: Optional[int] = None) -> None:
        """This arena's robots to `poses` (map frame), which become their start poses; with a
        `seed`, their noise streams restart from it."""
        request = ResetSimRequest(arena=self.arena, robots=self.robots,
                                  poses=[Pose2DMsg(x, y, yaw) for x, y, yaw in poses],
                                  reseed=seed is not None, seed=seed if seed is not None else 0)
        response = call_bounded(lambda: self._reset(request), self.answer_wall, f"{SIMULATOR}/reset")
        if not response.success:
            raise SimulatorLost(f"{SIMULATOR}/reset refused: {response.message}")

    # ------------------------------------------------------------------ state

    def has_state(self, tick: int, stamp: float) -> bool:
        """Every robot's ground truth of `stamp` has arrived and, in lock-step, every controller
        has answered `tick` (so it has seen everything up to it): told by the answers themselves
        with one arena, by /clock one tick past `stamp` with several (tracks_answers)."""
        config = self.config
        if self._answers_from_clock and rospy.get_time() < stamp + 1.0 / config.physics_rate - 1e-9:
            return False
        with self._lock:
            return (all(t is not None and t[0] >= stamp - 1e-9 for t in self._truth)
                    and all(self._acked[i] >= tick for i, ns in enumerate(self.robots)
                            if self.tracks_answers and config.answers_lockstep(ns) and i not in self._released))

    def wait_caught_up(self, tick: int, stamp: float, timeout_wall: Optional[float] = None) -> None:
        """Waits until has_state(tick, stamp), at most `timeout_wall` s (default: the time after
        which the simulator counts as lost)."""
        try:
            wait_wall(lambda: self.has_state(tick, stamp), timeout_wall or self.answer_wall,
                      f"ground truth and lock-step answers of tick {tick}")
        except SimulatorLost as lost:
            if self.on_stall is not None and self.on_stall():
                self.wait_caught_up(tick, stamp, timeout_wall)
                return
            raise SimulatorLost(f"{lost}; {self.describe_lag(tick, stamp)}") from None

    def describe_lag(self, tick: int, stamp: Optional[float] = None) -> str:
        """Which robots have not answered `tick` (or sent ground truth of `stamp`)."""
        config = self.config
        with self._lock:
            silent = [ns for i, ns in enumerate(self.robots) if self.tracks_answers and config.answers_lockstep(ns)
                      and i not in self._released and self._acked[i] < tick]
            no_truth = [ns for i, ns in enumerate(self.robots)
                        if stamp is not None and (self._truth[i] is None or self._truth[i][0] < stamp - 1e-9)]
        parts = []
        if silent:
            parts.append("no lock-step answer from the controller (move_base) of " + ", ".join(silent))
        if no_truth:
            parts.append("no ground truth from the simulator for " + ", ".join(no_truth))
        if self._answers_from_clock:
            parts.append("the simulator's log names the controllers it waits for")
        return "; ".join(parts) or "every robot answered"

    def goal_end_tick(self, robot: int) -> int:
        """The tick on which the robot's lock-step controller last ended a goal, as its latest
        answer says (0: none yet; with one arena only: tracks_answers)."""
        with self._lock:
            return self._goal_end[robot]

    def poses(self) -> List[Optional[Tuple[float, float, float]]]:
        with self._lock:
            return [t[1] if t is not None else None for t in self._truth]

    def forget_poses(self) -> None:
        with self._lock:
            self._truth = [None] * len(self.robots)

    def collisions_between(self, start: float, end: float) -> List[int]:
        """Collision events per robot with start < sim time <= end."""
        counts = [0] * len(self.robots)
        with self._lock:
            for stamp, robot in self._collisions:
                if start < stamp <= end + 1e-9:
                    counts[robot] += 1
            self._collisions = [c for c in self._collisions if c[0] > end]
        return counts

    # ------------------------------------------------------------------ callbacks

    def _on_truth(self, msg: Odometry, robot: int) -> None:
        p = msg.pose.pose
        with self._lock:
            self._truth[robot] = (msg.header.stamp.to_sec(), (p.position.x, p.position.y, quaternion_to_yaw(p.orientation)))

    def _on_ack(self, msg: LockstepAck) -> None:
        robot = self._index.get(msg.robot)
        if robot is not None:
            with self._lock:
                self._acked[robot] = max(self._acked[robot], int(msg.tick))
                self._goal_end[robot] = max(self._goal_end[robot], int(msg.goal_end_tick))

    def _on_collision(self, msg: CollisionEvent) -> None:
        robot = self._index.get(msg.robot)
        if robot is not None and msg.arena == self.arena:
            with self._lock:
                self._collisions.append((msg.stamp.to_sec(), robot))
