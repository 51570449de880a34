"""The decision process in event mode: a robot that comes free decides at once, the others keep driving.

The same interface as the paper's synchronous process (env/task_env.py): reset() and step(actions)
with one action per robot, but a step is a decision instant, and only the robots in
`StepOutput.deciding` decide at it; the actions of the others are ignored (their mask rows allow
None alone). model/event_rules.py decides what happens (holds, service, who is due), the executor
drives the legs (env/executor.py's event interface), model/reward.py scores each robot.

Rewards: per robot and per transition (from one decision instant to the next) the paper's
components over that stretch of the robot's own time: r_idle for the time it waited (idle or
holding for predecessors), r_col for its collision events, and at the end of an attempt (its
task finished, its leg failed or wasted) r_logic and r_nav of that attempt. A robot's return over
its own decision interval is the sum of its transitions' rewards (model/reward.py, event_rewards),
each discounted by the elapsed
time: `info.step_duration` is the transition's length Δt (the trainer discounts by γ^Δt, see
mappo/config.py `discount_seconds`).

Observations keep the synchronous layout (one encoder, so an actor serves both modes): a busy
robot is shown where it will come free (its task's goal), its current task as the task it
drives to, holds at or serves; tasks taken by a busy robot are in `info.robot_tasks` (the
claims of a policy that decides in turn) and masked for the other robots.

A live fleet (env/live_fleet.py): tasks not yet known, and cancelled ones, are shown finished
and masked; robots that have left never decide; requests apply between decision instants.
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Sequence

import numpy as np

from marl_mrta.env.api import REWARD_COMPONENTS, StepInfo, StepOutput
from marl_mrta.env.live_fleet import LiveFleetMixin
from marl_mrta.env.observation import float32_array
from marl_mrta.env.settings import TaskSettings
from marl_mrta.model.event_rules import DRIVING, HOLDING, IDLE, SERVING, EventOutcome, EventRules
from marl_mrta.model.reward import RewardConfig, event_rewards
from marl_mrta.model.scenario import Scenario
from marl_mrta.model.schedule import EpisodeRecord, ScheduleEntry

#: Decision instants after which an episode that has not ended stops (every robot None forever
#: with the timeout out of reach cannot happen: the timeout ends it; this guards a broken executor).
MAX_INSTANTS = 100_000


class EventTaskEnvironment(LiveFleetMixin):
    """Implements env.api.TaskAllocationEnv in event mode for one scenario and one event executor."""

    decision_mode = "event"

    def __init__(self, scenario: Scenario, executor, reward: RewardConfig, settings: TaskSettings,
                 seed: Optional[int] = None, travel_model=None):
        self.scenario = scenario
        self.executor = executor
        self.reward = reward
        self.settings = settings
        self.n_agents = scenario.n_robots
        self._set_scenario(scenario)   # scenario, task count, encoder, goals (LiveFleetMixin)
        self._timeout = scenario.episode_timeout
        self.rules = EventRules(scenario.n_robots, scenario.predecessors, [t.service_time for t in scenario.tasks],
                                settings.min_step, [t.release <= 0.0 for t in scenario.tasks])
        self._next_seed = seed
        self.record: Optional[EpisodeRecord] = None
        self.over = False
        self._init_live(travel_model)

    # ------------------------------------------------------------------ interface

    def reset(self, seed: Optional[int] = None) -> StepOutput:
        if seed is None:
            seed, self._next_seed = self._next_seed, None
        self._restore_scenario()
        self.executor.reset(seed)
        n, m = self.n_agents, self.n_tasks
        self.elapsed = 0.0
        self.step_index = 0
        self.rules.reset(0.0)
        self.over = False
        self.previous_task: List[Optional[int]] = [None] * n
        self.last_nav = [0.0] * n
        self.decisions = [0] * n
        self.record = EpisodeRecord(self.scenario.name, [r.id for r in self.scenario.robots],
                                    [t.id for t in self.scenario.tasks], finish_time=self.rules.finish_time,
                                    finished_by=self.rules.finished_by, task_logic_correct=[None] * m,
                                    nav_time=[0.0] * n, idle_time=[0.0] * n, collisions=[0] * n,
                                    decision_mode="event")
        self._finish_order = 0
        self._live_reset()
        zeros = np.zeros(n, dtype=np.float32)
        return self._output(zeros, {name: zeros.copy() for name in REWARD_COMPONENTS}, False, False,
                            StepInfo(step=0, elapsed=0.0, finished=[False] * m, robot_tasks=[None] * n))

    def resume(self, nodes: Sequence[int], finished: Sequence[bool], elapsed: float, step_index: int,
               at_task: Optional[Dict[int, int]] = None) -> StepOutput:
        """An episode taken up midway, as a robot observes it (evaluation/lookahead.py): the robots
        standing on `nodes` of the executor's table, `finished` tasks done, `elapsed` s and
        `step_index` instants gone, and the robots of `at_task` at those tasks (busy robots, shown
        where they come free), serving or holding from now; the others decide. Embedded executor."""
        if len(finished) != self.n_tasks:
            raise ValueError(f"finished: {len(finished)} flags, the scenario has {self.n_tasks} tasks")
        self.reset()
        self.executor.place(nodes)
        self.executor.set_clock(elapsed)
        self.elapsed, self.step_index = float(elapsed), int(step_index)
        self.rules.resume(self.elapsed, [bool(f) for f in finished], dict(at_task or {}))
        for task, done in enumerate(finished):
            if done:
                self.record.task_logic_correct[task] = True
        return self.current_output()

    def current_output(self) -> StepOutput:
        """The episode as it stands, the due robots deciding (no transition: zero rewards)."""
        zeros = np.zeros(self.n_agents, dtype=np.float32)
        return self._output(zeros, {name: zeros.copy() for name in REWARD_COMPONENTS}, False, False,
                            StepInfo(step=self.step_index, elapsed=self.elapsed, finished=list(self.rules.finished),
                                     robot_tasks=[r.task for r in self.rules.robots]))

    def step(self, actions: Sequence[int]) -> StepOutput:
        if self.record is None or self.over:
            raise RuntimeError("step() called before reset() or after the episode ended")
        if len(actions) != self.n_agents:
            raise ValueError(f"expected {self.n_agents} actions, got {len(actions)}")
        none = self.n_tasks
        values = list(map(int, actions))
        if min(values) < 0 or max(values) > none:
            raise ValueError(f"actions {values} outside 0..{none}")
        rules, executor, record = self.rules, self.executor, self.record
        start = self.elapsed
        deciding = sorted(rules.due)
        joint: List[Optional[int]] = [None] * self.n_agents
        for robot in deciding:
            task = None if values[robot] == none else values[robot]
            state = rules.robots[robot]
            was_holding = state.phase == HOLDING and state.task == task
            left_task = rules.attempts[robot] if state.phase == HOLDING and not was_holding else None
            rules.assign(robot, task, start)
            if left_task is not None:   # it leaves the task it held at, unserved: in the record
                self._record_attempt(left_task)
            self.decisions[robot] += 1
            joint[robot] = task
            if task is not None and not was_holding:
                self._note_dispatch(robot, self.robot_nodes()[robot])
                executor.dispatch(robot, task)
                self.previous_task[robot] = task
        record.joint_actions.append(joint)

        n = self.n_agents
        waited = [0.0] * n
        collisions = [0] * n
        outcome = EventOutcome(start)
        now = start
        aborted, abort_reason = False, ""
        for _ in range(MAX_INSTANTS):
            if rules.due or rules.done:
                break
            if not any(rules.present(i) for i in range(self.n_agents)) and not self._awaits_changes():
                aborted, abort_reason = True, "every robot has left the fleet"
                break
            timer = rules.next_timer()
            until = min(timer if timer is not None else math.inf, self._next_timed_time(), self._timeout)
            if until <= now and not rules.running():
                break   # the timeout: nothing left to wait for
            result = executor.advance(until)
            reached_at = result.time
            # Phases are constant between instants: the stretch up to this one is waited or worked.
            for i, robot in enumerate(rules.robots):
                if robot.phase in (IDLE, HOLDING):
                    waited[i] += reached_at - now
            for i, events in enumerate(result.collisions):
                collisions[i] += events
            now = reached_at
            if result.aborted:
                aborted, abort_reason = True, result.abort_reason
                break
            for leg in result.legs:
                if rules.robots[leg.robot].phase != DRIVING:
                    continue   # a leg stopped by a request or a robot's departure, ending as it stopped
                ended = rules.leg_ended(leg.robot, now, leg.reached, leg.failure)
                if ended is not None:
                    outcome.ended.append(ended)
            for robot, reason in result.left:   # robots the executor lost (on_robot_fault continue)
                if rules.present(robot):
                    self._robot_leaves(robot, now, reason, outcome)
                    self.fleet_version += 1
            self._apply_timed(now, outcome)
            rules.advance_to(now, outcome)
            if now >= self._timeout - 1e-9 or self.interrupted():
                break
        duration = now - start
        self.elapsed = now
        self.step_index += 1
        record.step_durations.append(duration)

        # Rewards: each robot's stretch of this transition, and the attempts that ended in it.
        ended_by = {a.robot: a for a in outcome.ended}
        for i, attempt in ended_by.items():
            self.last_nav[i] = attempt.nav_time
        ended = [i in ended_by for i in range(n)]
        finished_attempt = [i in ended_by and ended_by[i].finish_time is not None for i in range(n)]
        breakdown = event_rewards(self.reward, ended, finished_attempt, self.last_nav, collisions, waited)
        for i in range(n):
            record.idle_time[i] += waited[i]
            record.collisions[i] += collisions[i]
        for attempt in outcome.ended:
            self._record_attempt(attempt)
            record.nav_time[attempt.robot] += attempt.nav_time

        done = rules.done
        truncated = not done and (aborted or now >= self._timeout - 1e-9 or self.step_index >= MAX_INSTANTS)
        finished_task: List[Optional[int]] = [None] * n
        for task, robot, _ in outcome.finished:
            finished_task[robot] = task
        info = StepInfo(self.step_index, now, list(rules.finished), duration, [self.last_nav[i] for i in range(n)],
                        waited, collisions, [r.phase in (HOLDING, SERVING) for r in rules.robots], finished_task,
                        [True] * n, [ended_by[i].failure if i in ended_by else "" for i in range(n)],
                        [None] * n, [ended_by[i].held if i in ended_by else 0.0 for i in range(n)],
                        robot_tasks=[r.task for r in rules.robots], attempt_ended=ended)
        if done or truncated:
            self.over = True
            for i, robot in enumerate(rules.robots):   # attempts cut by the end: in the record unfinished
                attempt = rules.attempts[i]
                if attempt is not None:
                    if robot.phase == DRIVING:
                        attempt.nav_time = now - robot.leg_start
                    self._record_attempt(attempt)
            record.makespan = now
            record.complete = done
            record.truncated = truncated
            record.abort_reason = abort_reason
            info.episode = record
            info.abort_reason = abort_reason
        table = float32_array([*breakdown.logic, *breakdown.nav, *breakdown.collision, *breakdown.idle,
                               *breakdown.total])
        *components, rewards = table.reshape(len(REWARD_COMPONENTS) + 1, n)
        return self._output(rewards, dict(zip(REWARD_COMPONENTS, components)), done, truncated, info)

    # ------------------------------------------------------------------ helpers

    def _record_attempt(self, attempt) -> None:
        finished = attempt.finish_time is not None
        order = None
        if finished:
            self._finish_order += 1
            order = self._finish_order
            self.record.task_logic_correct[attempt.task] = True   # held for its predecessors: always in order
        end = attempt.arrived_at if attempt.arrived_at is not None else attempt.decided_at + attempt.nav_time
        self.record.entries.append(ScheduleEntry(attempt.robot, attempt.task, self.decisions[attempt.robot] - 1,
                                                 attempt.decided_at, attempt.arrived_at, end, finished, order, True,
                                                 attempt.finish_time, attempt.service_start))

    def ready_flags(self) -> List[bool]:
        return [self.rules.ready(j) for j in range(self.n_tasks)]

    def _mask(self, deciding: Sequence[int]) -> np.ndarray:
        mode = self.settings.mask
        rules = self.rules
        mask = np.zeros((self.n_agents, self.n_actions), dtype=bool)
        mask[:, -1] = True
        for i in deciding:
            for j in range(self.n_tasks):
                if not rules.known[j] or rules.cancelled[j]:
                    continue   # not (or no longer) in the fleet's task set
                if mode == "none":
                    mask[i, j] = True
                elif not rules.finished[j] and not rules.taken(j, by_other_than=i):
                    mask[i, j] = mode == "finished" or rules.ready(j) or rules.robots[i].task == j
        return mask

    def _output(self, rewards, components, done, truncated, info) -> StepOutput:
        rules = self.rules
        deciding = [] if (done or truncated) else sorted(rules.due)
        poses = self.executor.poses()
        # A busy robot is shown where it comes free: its task's goal.
        shown = [self._goal_pose[r.task] if r.phase != IDLE and r.task is not None else poses[i]
                 for i, r in enumerate(rules.robots)]
        current = [r.task for r in rules.robots]
        current_goal = [self._goal_xy[t] if t is not None else (p[0], p[1]) for t, p in zip(current, shown)]
        previous_goal = [self._goal_xy[t] if t is not None else (p[0], p[1]) for t, p in zip(self.previous_task, poses)]
        reached = [r.phase in (HOLDING, SERVING) for r in rules.robots]
        # Tasks not known yet, and cancelled ones, are shown as finished: nothing to do there.
        closed = [not rules.open(j) for j in range(self.n_tasks)]
        task_part = self.encoder.task_part(closed, self.ready_flags(), rules.finish_time,
                                           self.record.task_logic_correct)
        obs, state = self.encoder.encode(self.step_index, self.elapsed, shown, current, self.previous_task,
                                         current_goal, previous_goal, reached, self.last_nav, info.step_duration,
                                         task_part)
        flags = np.zeros(self.n_agents, dtype=bool)
        flags[deciding] = True
        return StepOutput(obs, state, rewards, components, done, truncated, self._mask(deciding), info, deciding=flags)
