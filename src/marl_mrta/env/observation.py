"""Per-robot observation (paper Table 5, normalised) and the critic's global state.

Observation of robot i, in this order (every value in [0, 1] or a one-hot):
  step index / (2·n_tasks) (capped at 1)  ·  episode time / timeout
  pose at the step start: x, y (map-normalised), (cos yaw + 1)/2, (sin yaw + 1)/2   (z is 0 in 2D)
  robot id (one-hot, n_robots)
  current task and previous task (one-hot, n_tasks + 1; last = None)
  current goal and previous goal: x, y (map-normalised; None = where the robot stood)
  reached-goal flag of the current task
  category of the current task (one-hot over the scenario's categories + None)
  navigation duration and step duration of the last step / t_max (capped at 1)
  shared: finished flag per task, ready flag per task (open, every predecessor finished)
  shared: the other robots' x, y (in robot order)
Global state: every robot's observation, then episode time / timeout, step fraction, and per
task its finish time / timeout (0 while open) and its logic-correct flag.
"""
from __future__ import annotations

import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from marl_mrta.model.scenario import Scenario


class ObservationEncoder:
    def __init__(self, scenario: Scenario, map_bounds: Tuple[float, float, float, float]):
        self.n_robots = scenario.n_robots
        self.n_tasks = scenario.n_tasks
        self.timeout = scenario.episode_timeout
        self.t_max = scenario.nav_thresholds.t_max
        self.step_scale = 2.0 * scenario.n_tasks
        self.x0, self.y0, self.width, self.height = map_bounds
        categories = scenario.categories
        n_cat = len(categories)
        none_task = [0.0] * scenario.n_tasks + [1.0]
        self.task_onehot = [[1.0 if k == j else 0.0 for k in range(scenario.n_tasks + 1)]
                            for j in range(scenario.n_tasks)] + [none_task]
        self.category_onehot = [[1.0 if c == categories.index(t.category) else 0.0 for c in range(n_cat + 1)]
                                for t in scenario.tasks] + [[0.0] * n_cat + [1.0]]
        self.robot_onehot = [[1.0 if k == i else 0.0 for k in range(self.n_robots)] for i in range(self.n_robots)]
        self.others = [[k for k in range(self.n_robots) if k != i] for i in range(self.n_robots)]
        self.obs_dim = (2 + 4 + self.n_robots + 2 * (self.n_tasks + 1) + 4 + 1 + (n_cat + 1) + 2
                        + 2 * self.n_tasks + 2 * (self.n_robots - 1))
        self.state_dim = self.n_robots * self.obs_dim + 2 + 2 * self.n_tasks

    def xy(self, x: float, y: float) -> List[float]:
        return [(x - self.x0) / self.width, (y - self.y0) / self.height]

    def encode(self, step_index: int, elapsed: float, poses: Sequence[Tuple[float, float, float]],
               current_task: Sequence[Optional[int]], previous_task: Sequence[Optional[int]],
               current_goal: Sequence[Tuple[float, float]], previous_goal: Sequence[Tuple[float, float]],
               reached: Sequence[bool], last_nav: Sequence[float], last_step: float,
               finished: Sequence[bool], ready: Sequence[bool]) -> np.ndarray:
        n_tasks, t_max = self.n_tasks, self.t_max
        x0, y0, width, height = self.x0, self.y0, self.width, self.height
        head = [min(step_index / self.step_scale, 1.0), min(elapsed / self.timeout, 1.0)]
        shared = [1.0 if f else 0.0 for f in finished] + [1.0 if r else 0.0 for r in ready]
        positions = [[(p[0] - x0) / width, (p[1] - y0) / height] for p in poses]
        step_norm = min(last_step / t_max, 1.0)
        rows = []
        task_onehot, category_onehot = self.task_onehot, self.category_onehot
        for i in range(self.n_robots):
            yaw = poses[i][2]
            cur = current_task[i]
            cur = n_tasks if cur is None else cur
            prev = previous_task[i]
            prev = n_tasks if prev is None else prev
            goal, old_goal = current_goal[i], previous_goal[i]
            row = [*head, *positions[i], (math.cos(yaw) + 1.0) * 0.5, (math.sin(yaw) + 1.0) * 0.5,
                   *self.robot_onehot[i], *task_onehot[cur], *task_onehot[prev],
                   (goal[0] - x0) / width, (goal[1] - y0) / height,
                   (old_goal[0] - x0) / width, (old_goal[1] - y0) / height, 1.0 if reached[i] else 0.0,
                   *category_onehot[cur], min(last_nav[i] / t_max, 1.0), step_norm, *shared]
            for k in self.others[i]:
                row += positions[k]
            rows.append(row)
        return np.array(rows, dtype=np.float32)

    def state(self, obs: np.ndarray, step_index: int, elapsed: float,
              finish_time: Sequence[Optional[float]], task_correct: Sequence[Optional[bool]]) -> np.ndarray:
        timeout = self.timeout
        tail = [min(elapsed / timeout, 1.0), min(step_index / self.step_scale, 1.0)]
        tail += [0.0 if t is None else min(t / timeout, 1.0) for t in finish_time]
        tail += [1.0 if c else 0.0 for c in task_correct]
        state = np.empty(self.state_dim, dtype=np.float32)
        split = obs.size
        state[:split] = obs.ravel()
        state[split:] = tail
        return state
