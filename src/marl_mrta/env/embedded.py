"""The embedded executor: robots move on the scenario's travel-time table, no ROS.

Leg time = turn / ω + path length · stretch / (v · linear_speed_scale) + pauses, from one noise
profile of config/noise_profiles.yaml (the figures the simulator applies too): the ideal profile
uses the table's times unchanged; a noisy one stretches each path by 1 + |N(0, path_stretch_sd)|,
drives it at the achieved speed and adds Poisson pauses (pause_rate per second of driving, each
pause_duration long; the paper's measured TB3 behaviour: 0.19 m/s for 0.22, 3–6 pauses of
0.5–1.2 s per episode). A leg longer than its goal timeout fails (model/goal_timeout.py: a fixed
timeout, or with auto the leg's own from its nominal time in the table); a robot that fails or is
cut by the episode's time limit stays where the step began (the table knows no intermediate poses).
With proximity_collisions, robots are placed along their paths over time and a pair whose
centres come closer than `collision_distance` (their footprints meet) counts one collision
event for each of them.
"""
from __future__ import annotations

import random
from typing import List, Optional, Sequence, Set, Tuple, Union

import numpy as np

from marl_mrta.env.executor import EventAdvance, LegEnd, RobotOutcome, StepOutcome
from marl_mrta.model.goal_timeout import GoalTimeout
from marl_mrta.model.noise import NoiseProfile
from marl_mrta.model.travel import TravelTable


class EmbeddedExecutor:
    """Executor on a TravelTable (see env/executor.py for the step contract)."""

    def __init__(self, table: TravelTable, n_robots: int, profile: NoiseProfile,
                 goal_timeout: Union[float, GoalTimeout], seed: Optional[int] = None,
                 collision_distance: float = 0.0, collision_dt: float = 0.2):
        self.table = table
        self.n_robots = n_robots
        self.profile = profile
        rule = goal_timeout if isinstance(goal_timeout, GoalTimeout) else GoalTimeout(float(goal_timeout))
        self.goal_timeout = rule
        # Per leg (start node, goal node) its timeout: one number for a fixed rule, else a table
        # from the nominal times (the same the ROS executors and the planners use).
        self._fixed_limit = rule.seconds
        self._limits = None if rule.seconds is not None else [[rule.leg(t) for t in row] for row in table.time_rows]
        self.nominal = profile.moves_as_planned
        self.collision_distance = collision_distance
        self.collision_dt = collision_dt
        self._rng = random.Random(seed)
        self._pending_seed: Optional[int] = None
        self._nodes = list(range(n_robots))
        self._in_contact: Set[Tuple[int, int]] = set()
        self.clock = 0.0
        # Event mode: per robot, its leg under way (end time, goal node, failure) or None.
        self._legs: List[Optional[Tuple[float, int, str]]] = [None] * n_robots

    def reset(self, seed: Optional[int] = None) -> None:
        if seed is not None:
            self._pending_seed = seed   # seeded on first use: the ideal profile draws nothing
        self._nodes = list(range(self.n_robots))
        self._in_contact = set()
        self.clock = 0.0
        self._legs = [None] * self.n_robots

    def place(self, nodes: Sequence[int]) -> None:
        """Stand the robots on these nodes of the table (after reset(): an episode resumed midway)."""
        if len(nodes) != self.n_robots or not all(0 <= int(node) < self.table.n_nodes for node in nodes):
            raise ValueError(f"nodes {list(nodes)}: one node of the table per robot ({self.n_robots})")
        self._nodes = [int(node) for node in nodes]
        self._legs = [None] * self.n_robots

    def set_clock(self, now: float) -> None:
        """The clock of an episode resumed midway (event mode): legs dispatched from now on end
        their leg time after it."""
        self.clock = float(now)

    def leg_timeout(self, start: int, goal: int) -> float:
        """s the leg from node `start` to node `goal` may take before it fails."""
        return self._fixed_limit if self._limits is None else self._limits[start][goal]

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
        drive = length / (self.table.model.linear_speed * p.linear_speed_scale)
        pauses = 0.0
        if p.pause_rate > 0.0:
            shortest, longest = p.pause_duration
            t = rng.expovariate(p.pause_rate)
            while t < drive:
                pauses += rng.uniform(shortest, longest)
                t += rng.expovariate(p.pause_rate)
        return max(self.table.turn_rows[start][goal] + drive + pauses, self.table.model.min_goal_time)

    def start_step(self, goals: Sequence[Optional[int]], time_limit: float) -> StepOutcome:
        outcomes: List[RobotOutcome] = []
        legs = []
        nodes, fixed, limits = self._nodes, self._fixed_limit, self._limits
        nominal = self.table.time_rows if self.nominal else None   # the table's times, nothing drawn
        for robot, task in enumerate(goals):
            start = nodes[robot]
            if task is None:
                outcomes.append(RobotOutcome(False, False, 0.0))
                legs.append((start, start, 0.0))
                continue
            goal = self.n_robots + task
            nav = nominal[start][goal] if nominal is not None else self.leg_time(start, goal)
            failure = ""
            goal_timeout = fixed if limits is None else limits[start][goal]
            if nav > goal_timeout:
                nav, failure = goal_timeout, "goal timeout"
            if nav > time_limit:
                nav, failure = time_limit, "episode time limit"
            legs.append((start, goal, nav))
            if not failure:
                nodes[robot] = goal
            outcomes.append(RobotOutcome(True, not failure, nav, 0, failure))
        if self.profile.proximity_collisions and self.n_robots > 1:
            for robot, events in enumerate(self._proximity_events(legs)):
                outcomes[robot].collisions = events
        return StepOutcome(outcomes)

    def finish_step(self, duration: float) -> None:
        self.clock += duration

    # ------------------------------------------------------------------ event mode

    def dispatch(self, robot: int, task: int) -> None:
        """The robot leaves its node for the task's now; a leg longer than its goal timeout fails
        at the timeout, where the robot stays."""
        goal = self.n_robots + task
        start = self._nodes[robot]
        nav = self.leg_time(start, goal)
        failure = ""
        goal_timeout = self.leg_timeout(start, goal)
        if nav > goal_timeout:
            nav, failure = goal_timeout, "goal timeout"
        self._legs[robot] = (self.clock + nav, goal, failure)

    def advance(self, until: float) -> EventAdvance:
        ends = [leg[0] for leg in self._legs if leg is not None]
        time = min([until] + ends)
        ended = []
        for robot, leg in enumerate(self._legs):
            if leg is not None and leg[0] <= time + 1e-9:
                end, goal, failure = leg
                if not failure:
                    self._nodes[robot] = goal
                ended.append(LegEnd(robot, not failure, failure))
                self._legs[robot] = None
        self.clock = max(self.clock, time)
        return EventAdvance(self.clock, ended, [0] * self.n_robots)

    def stop(self, robot: int) -> None:
        """The robot's leg dropped: it stays on the node it left from (the table knows no
        intermediate poses, as for a leg that fails)."""
        self._legs[robot] = None

    def add_goals(self, scenario, table: TravelTable) -> None:
        """The table of the scenario with tasks added (their nodes after the others')."""
        self.table = table
        if self._limits is not None:
            self._limits = [[self.goal_timeout.leg(t) for t in row] for row in table.time_rows]

    def nodes(self) -> List[int]:
        """The table node each robot stands on (a driving robot: the one it left from)."""
        return list(self._nodes)

    def poses(self) -> List[Tuple[float, float, float]]:
        node_poses = self.table.node_poses
        return [node_poses[node] for node in self._nodes]

    def _proximity_events(self, legs: Sequence[Tuple[int, int, float]]) -> List[int]:
        """Collision events per robot: pairs entering `collision_distance` during the step."""
        horizon = max(nav for _, _, nav in legs)
        times = np.arange(0.0, horizon + self.collision_dt, self.collision_dt)
        tracks = []
        for start, goal, nav in legs:
            path = self.table.paths[start][goal]
            if nav <= 0.0 or start == goal:
                x, y = self.table.node_poses[start][:2]
                tracks.append(np.broadcast_to(np.array([x, y]), (len(times), 2)))
                continue
            along = self.table.path_along[start][goal]
            turn = min(self.table.turn_rows[start][goal], nav)
            drive = max(nav - turn, 1e-9)
            s = np.clip((times - turn) / drive, 0.0, 1.0) * along[-1]
            tracks.append(np.column_stack([np.interp(s, along, path[:, 0]), np.interp(s, along, path[:, 1])]))
        events = [0] * len(legs)
        limit = self.collision_distance
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
