"""The decision process of Algorithm 1 over any executor: the one implementation of the task rules.

One step: every robot gets a task index or None (index n_tasks); the executor drives the
robots; model/rules.py decides finishes, order and timing; model/reward.py scores each robot;
the episode ends when every task is finished (done) or at the timeout or an abort (truncated).
"""
from __future__ import annotations

from typing import List, Optional, Sequence

import numpy as np

from marl_mrta.model.scenario import Scenario
from marl_mrta.model.reward import RewardConfig, step_rewards
from marl_mrta.model.rules import resolve_step
from marl_mrta.model.schedule import EpisodeRecord, ScheduleEntry
from marl_mrta.env.api import REWARD_COMPONENTS, StepInfo, StepOutput
from marl_mrta.env.executor import Executor
from marl_mrta.env.observation import ObservationEncoder, float32_array
from marl_mrta.env.settings import TaskSettings


class TaskEnvironment:
    """Implements env.api.TaskAllocationEnv for one scenario and one executor (synchronous mode)."""

    decision_mode = "synchronous"

    def __init__(self, scenario: Scenario, executor: Executor, reward: RewardConfig, settings: TaskSettings,
                 seed: Optional[int] = None):
        self.scenario = scenario
        self.executor = executor
        self.reward = reward
        self.settings = settings
        self.n_agents = scenario.n_robots
        self.n_tasks = scenario.n_tasks
        self.n_actions = scenario.n_tasks + 1
        self.encoder = ObservationEncoder(scenario)
        self.obs_dim = self.encoder.obs_dim
        self.state_dim = self.encoder.state_dim
        self._predecessors = [list(p) for p in scenario.predecessors]
        self._service = [t.service_time for t in scenario.tasks]
        self._goal_xy = [(t.goal.x, t.goal.y) for t in scenario.tasks]
        self._robot_ids = [r.id for r in scenario.robots]
        self._task_ids = [t.id for t in scenario.tasks]
        self._timeout = scenario.episode_timeout
        self._next_seed = seed
        self.record: Optional[EpisodeRecord] = None

    # ------------------------------------------------------------------ interface

    def reset(self, seed: Optional[int] = None) -> StepOutput:
        if seed is None:
            seed, self._next_seed = self._next_seed, None
        self.executor.reset(seed)
        n, m = self.n_agents, self.n_tasks
        self.elapsed = 0.0
        self.step_index = 0
        self.finished = [False] * m
        self.finish_time: List[Optional[float]] = [None] * m
        self.finished_by: List[Optional[int]] = [None] * m
        self.task_correct: List[Optional[bool]] = [None] * m
        self.n_finished = 0
        poses = self.executor.poses()
        self.current_task: List[Optional[int]] = [None] * n
        self.previous_task: List[Optional[int]] = [None] * n
        self.current_goal = [(p[0], p[1]) for p in poses]
        self.previous_goal = list(self.current_goal)
        self.reached = [False] * n
        self.last_nav = [0.0] * n
        self.last_step = 0.0
        self.over = False
        self.record = EpisodeRecord(self.scenario.name, list(self._robot_ids), list(self._task_ids),
                                    finish_time=self.finish_time, finished_by=self.finished_by,
                                    task_logic_correct=self.task_correct, nav_time=[0.0] * n,
                                    idle_time=[0.0] * n, collisions=[0] * n)
        self._tasks_changed()
        *components, total = np.zeros((len(REWARD_COMPONENTS) + 1, n), dtype=np.float32)
        return self._output(poses, total, dict(zip(REWARD_COMPONENTS, components)), False, False,
                            StepInfo(step=0, elapsed=0.0, finished=list(self.finished)))

    def resume(self, nodes: Sequence[int], finished: Sequence[bool], elapsed: float, step_index: int) -> StepOutput:
        """An episode taken up midway, as a robot observes it: the robots standing on `nodes` of the
        executor's table, `finished` tasks done (in order; their finish times are not known, so
        `elapsed`), `elapsed` s and `step_index` steps gone. The record holds the rest of the
        episode; its makespan counts from the start. The executor must place robots (embedded)."""
        if len(finished) != self.n_tasks:
            raise ValueError(f"finished: {len(finished)} flags, the scenario has {self.n_tasks} tasks")
        self.reset()
        self.executor.place(nodes)
        self.elapsed, self.step_index = float(elapsed), int(step_index)
        self.finished = [bool(flag) for flag in finished]
        for task, done in enumerate(self.finished):
            if done:
                self.finish_time[task], self.task_correct[task] = self.elapsed, True
        self.n_finished = sum(self.finished)
        poses = self.executor.poses()
        self.current_goal = [(p[0], p[1]) for p in poses]
        self.previous_goal = list(self.current_goal)
        self._tasks_changed()
        *components, total = np.zeros((len(REWARD_COMPONENTS) + 1, self.n_agents), dtype=np.float32)
        return self._output(poses, total, dict(zip(REWARD_COMPONENTS, components)), False, False,
                            StepInfo(step=self.step_index, elapsed=self.elapsed, finished=list(self.finished)))

    def step(self, actions: Sequence[int]) -> StepOutput:
        if self.record is None or self.over:
            raise RuntimeError("step() called before reset() or after the episode ended")
        if len(actions) != self.n_agents:
            raise ValueError(f"expected {self.n_agents} actions, got {len(actions)}")
        none = self.n_tasks
        values = list(map(int, actions))
        if min(values) < 0 or max(values) > none:
            raise ValueError(f"actions {values} outside 0..{none}")
        goals: List[Optional[int]] = [None if a == none else a for a in values]

        executor = self.executor
        start = self.elapsed
        time_limit = self._timeout - start
        poses_before = executor.poses()
        outcome = executor.start_step(goals, time_limit)
        robots = outcome.robots
        finished = self.finished
        resolution = resolve_step(goals, [r.nav_time for r in robots], [r.reached for r in robots],
                                  [r.collisions for r in robots], finished, self._predecessors,
                                  self._service, time_limit, self.settings.min_step,
                                  order_margin=self.settings.precedence_margin,
                                  hold_successors=self.settings.hold_successors)
        duration = resolution.duration
        executor.finish_step(duration)
        correct = resolution.correct_order
        finished_now = resolution.robot_finished
        nav = resolution.nav_time
        idle = resolution.idle_time
        collisions = resolution.collisions
        reached = resolution.reached
        busy = resolution.busy_time
        rewards = step_rewards(self.reward, [g is not None for g in goals], correct, finished_now, nav, collisions,
                               idle)

        record = self.record
        n_before = self.n_finished
        order_of = {}
        for k, done in enumerate(resolution.finished):
            finished[done.task] = True
            self.finish_time[done.task] = start + done.finish_time
            self.finished_by[done.task] = done.robot
            self.task_correct[done.task] = correct[done.robot]
            order_of[done.task] = n_before + k + 1
        step_index = self.step_index
        entries, total_nav, total_idle, total_collisions = (record.entries, record.nav_time, record.idle_time,
                                                            record.collisions)
        finished_task: List[Optional[int]] = [None] * self.n_agents
        finish_order: List[Optional[int]] = [None] * self.n_agents
        for i, goal in enumerate(goals):
            total_nav[i] += nav[i]
            total_idle[i] += idle[i]
            total_collisions[i] += collisions[i]
            if goal is not None:
                fin = finished_now[i]
                if fin:
                    finished_task[i], finish_order[i] = goal, order_of[goal]
                end = start + nav[i]
                entries.append(ScheduleEntry(i, goal, step_index, start, end if reached[i] else None, end, fin,
                                             finish_order[i], correct[i], start + busy[i] if fin else None))
        record.step_durations.append(duration)
        record.joint_actions.append(goals)
        if order_of:
            self.n_finished = n_before + len(order_of)
            self._tasks_changed()

        self.previous_task = self.current_task
        self.current_task = goals
        self.previous_goal = self.current_goal
        goal_xy = self._goal_xy
        self.current_goal = [goal_xy[g] if g is not None else (p[0], p[1]) for g, p in zip(goals, poses_before)]
        self.reached = reached
        self.last_nav = nav
        self.last_step = duration
        self.elapsed = elapsed = start + duration
        self.step_index = step_index + 1

        done = self.n_finished == self.n_tasks
        truncated = not done and (outcome.aborted or elapsed >= self._timeout - 1e-9)
        info = StepInfo(step_index + 1, elapsed, list(finished), duration, nav, idle, collisions, reached,
                        finished_task, correct, [r.failure for r in robots], finish_order, resolution.held)
        if done or truncated:
            self.over = True
            record.makespan = elapsed
            record.complete = done
            record.truncated = truncated
            record.abort_reason = outcome.abort_reason if outcome.aborted else ""
            info.episode = record
            info.abort_reason = record.abort_reason
        table = float32_array([*rewards.logic, *rewards.nav, *rewards.collision, *rewards.idle, *rewards.total])
        *components, total = table.reshape(len(REWARD_COMPONENTS) + 1, self.n_agents)
        return self._output(executor.poses(), total, dict(zip(REWARD_COMPONENTS, components)), done, truncated, info)

    # ------------------------------------------------------------------ helpers

    def ready_flags(self) -> List[bool]:
        """Per task: still open and every predecessor finished."""
        fin = self.finished
        ready = []
        for j, preds in enumerate(self._predecessors):
            ok = not fin[j]
            if ok:
                for p in preds:
                    if not fin[p]:
                        ok = False
                        break
            ready.append(ok)
        return ready

    def action_mask_row(self, ready: Sequence[bool]) -> List[bool]:
        mode = self.settings.mask
        if mode == "none":
            return [True] * self.n_actions
        if mode == "finished":
            return [not f for f in self.finished] + [True]
        return list(ready) + [True]

    def _tasks_changed(self) -> None:
        """What depends only on the finished tasks, computed again when one finishes, not every step."""
        ready = self.ready_flags()
        self._task_part = self.encoder.task_part(self.finished, ready, self.finish_time, self.task_correct)
        # Read-only: every output gets a copy of it.
        self._mask = np.frombuffer(bytes(self.action_mask_row(ready) * self.n_agents), dtype=bool).reshape(
            self.n_agents, self.n_actions)

    def _output(self, poses, rewards, components, done, truncated, info) -> StepOutput:
        obs, state = self.encoder.encode(self.step_index, self.elapsed, poses, self.current_task, self.previous_task,
                                         self.current_goal, self.previous_goal, self.reached, self.last_nav,
                                         self.last_step, self._task_part)
        return StepOutput(obs, state, rewards, components, done, truncated, self._mask.copy(), info)
