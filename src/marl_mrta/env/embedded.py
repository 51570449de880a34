"""The embedded executor: robots move on the scenario's travel-time table, no ROS.

Leg time = turn / ω + path length · stretch / v + pauses, where the nominal profile uses the
table's times unchanged and a noisy profile draws, per leg, v in [speed_min, speed_max], a
path stretch 1 + |N(0, path_stretch_sd)| and Poisson pauses of pause_min..pause_max seconds
(the paper's measured TB3 behaviour: 0.19 vs 0.22 m/s, 3–6 pauses of 0.5–1.2 s per episode).
A leg longer than the goal timeout fails; a robot that fails or is cut by the episode's time
limit stays where the step began (the table knows no intermediate poses).
Optional proximity collisions: robots are placed along their paths over time and a pair whose
centres come closer than `collision_distance` counts one collision event for each of them.
"""
from __future__ import annotations

import random
from dataclasses import dataclass
from typing import List, Optional, Sequence, Set, Tuple

import numpy as np

from marl_mrta.common.config import ConfigSection
from marl_mrta.model.travel import TravelTable
from marl_mrta.env.executor import RobotOutcome, StepOutcome


@dataclass(frozen=True)
class NoiseProfile:
    """How embedded navigation deviates from the nominal table (config/task_embedded.yaml)."""

    speed_min: float
    speed_max: float
    path_stretch_sd: float
    pause_rate: float            # pauses per second of driving
    pause_min: float
    pause_max: float
    proximity_collisions: bool
    collision_distance: float    # m between robot centres
    collision_dt: float = 0.2    # s, time resolution of the proximity check

    def is_nominal(self, nominal_speed: float) -> bool:
        return (self.speed_min == self.speed_max == nominal_speed and self.path_stretch_sd == 0.0
                and self.pause_rate == 0.0)

    @staticmethod
    def from_section(section: ConfigSection) -> "NoiseProfile":
        profile = NoiseProfile(
            speed_min=section.number("speed_min", minimum=1e-3),
            speed_max=section.number("speed_max", minimum=1e-3),
            path_stretch_sd=section.number("path_stretch_sd", minimum=0.0),
            pause_rate=section.number("pause_rate", minimum=0.0),
            pause_min=section.number("pause_min", minimum=0.0),
            pause_max=section.number("pause_max", minimum=0.0),
            proximity_collisions=section.boolean("proximity_collisions"),
            collision_distance=section.number("collision_distance", minimum=0.0),
            collision_dt=section.number("collision_dt", default=0.2, minimum=1e-3),
        )
        if profile.speed_min > profile.speed_max or profile.pause_min > profile.pause_max:
            from marl_mrta.common.config import ConfigError
            raise ConfigError(f"{section.source}: {section.path}: need speed_min <= speed_max and pause_min <= pause_max")
        return profile


class EmbeddedExecutor:
    """Executor on a TravelTable (see env/executor.py for the step contract)."""

    def __init__(self, table: TravelTable, n_robots: int, profile: NoiseProfile, goal_timeout: float,
                 seed: Optional[int] = None):
        self.table = table
        self.n_robots = n_robots
        self.profile = profile
        self.goal_timeout = goal_timeout
        self.nominal = profile.is_nominal(table.model.linear_speed)
        self._rng = random.Random(seed)
        self._pending_seed: Optional[int] = None
        self._nodes = list(range(n_robots))
        self._in_contact: Set[Tuple[int, int]] = set()
        self.clock = 0.0

    def reset(self, seed: Optional[int] = None) -> None:
        if seed is not None:
            self._pending_seed = seed   # seeded on first use: the nominal profile draws nothing
        self._nodes = list(range(self.n_robots))
        self._in_contact = set()
        self.clock = 0.0

    def leg_time(self, start: int, goal: int) -> float:
        """Seconds to drive from node `start` to node `goal` under the noise profile."""
        if self.nominal:
            return self.table.time_rows[start][goal]
        if self._pending_seed is not None:
            self._rng.seed(self._pending_seed)
            self._pending_seed = None
        p, rng = self.profile, self._rng
        length = self.table.length_rows[start][goal]
        if p.path_stretch_sd > 0.0:
            length *= 1.0 + abs(rng.gauss(0.0, p.path_stretch_sd))
        speed = rng.uniform(p.speed_min, p.speed_max) if p.speed_max > p.speed_min else p.speed_min
        drive = length / speed
        pauses = 0.0
        if p.pause_rate > 0.0:
            t = rng.expovariate(p.pause_rate)
            while t < drive:
                pauses += rng.uniform(p.pause_min, p.pause_max)
                t += rng.expovariate(p.pause_rate)
        return max(self.table.turn_rows[start][goal] + drive + pauses, self.table.model.min_goal_time)

    def start_step(self, goals: Sequence[Optional[int]], time_limit: float) -> StepOutcome:
        outcomes: List[RobotOutcome] = []
        legs = []
        for robot, task in enumerate(goals):
            start = self._nodes[robot]
            if task is None:
                outcomes.append(RobotOutcome(False, False, 0.0))
                legs.append((start, start, 0.0))
                continue
            goal = self.n_robots + task
            nav = self.leg_time(start, goal)
            failure = ""
            if nav > self.goal_timeout:
                nav, failure = self.goal_timeout, "goal timeout"
            if nav > time_limit:
                nav, failure = time_limit, "episode time limit"
            legs.append((start, goal, nav))
            if not failure:
                self._nodes[robot] = goal
            outcomes.append(RobotOutcome(True, not failure, nav, 0, failure))
        if self.profile.proximity_collisions and self.n_robots > 1:
            for robot, events in enumerate(self._proximity_events(legs)):
                outcomes[robot].collisions = events
        return StepOutcome(outcomes)

    def finish_step(self, duration: float) -> None:
        self.clock += duration

    def poses(self) -> List[Tuple[float, float, float]]:
        return [self.table.node_poses[node] for node in self._nodes]

    def _proximity_events(self, legs: Sequence[Tuple[int, int, float]]) -> List[int]:
        """Collision events per robot: pairs entering `collision_distance` during the step."""
        horizon = max(nav for _, _, nav in legs)
        times = np.arange(0.0, horizon + self.profile.collision_dt, self.profile.collision_dt)
        tracks = []
        for start, goal, nav in legs:
            path = self.table.paths[start][goal]
            if nav <= 0.0 or start == goal:
                x, y = self.table.node_poses[start][:2]
                tracks.append(np.broadcast_to(np.array([x, y]), (len(times), 2)))
                continue
            seg = np.hypot(*np.diff(path, axis=0).T)
            along = np.concatenate([[0.0], np.cumsum(seg)])
            turn = min(self.table.turn_rows[start][goal], nav)
            drive = max(nav - turn, 1e-9)
            s = np.clip((times - turn) / drive, 0.0, 1.0) * along[-1]
            tracks.append(np.column_stack([np.interp(s, along, path[:, 0]), np.interp(s, along, path[:, 1])]))
        events = [0] * len(legs)
        limit = self.profile.collision_distance
        for i in range(len(legs)):
            for j in range(i + 1, len(legs)):
                close = np.hypot(*(tracks[i] - tracks[j]).T) < limit
                entries = int(np.count_nonzero(close[1:] & ~close[:-1]))
                if close[0] and (i, j) not in self._in_contact:
                    entries += 1
                if close[-1]:
                    self._in_contact.add((i, j))
                else:
                    self._in_contact.discard((i, j))
                events[i] += entries
                events[j] += entries
        return events
