"""env.api.StepOutput <-> marl_mrta/TaskEnvOutput, and a live fleet's snapshot <->
marl_mrta/FleetStatus: the one place the wire format is defined.

The step information and its episode record travel as typed messages (StepInfo, EpisodeRecord,
ScheduleEntry); "none" is -1 for indices and a flag beside a float, so a client rebuilds
exactly what the environment returned.
"""
from __future__ import annotations

from typing import List, Optional, Sequence

import numpy as np

from marl_mrta.msg import EpisodeRecord as EpisodeRecordMsg
from marl_mrta.msg import FleetEvent as FleetEventMsg
from marl_mrta.msg import FleetStatus as FleetStatusMsg
from marl_mrta.msg import RobotStatus as RobotStatusMsg
from marl_mrta.msg import TaskStatus as TaskStatusMsg
from marl_mrta.msg import ScheduleEntry as ScheduleEntryMsg
from marl_mrta.msg import StepInfo as StepInfoMsg
from marl_mrta.msg import TaskEnvOutput

from marl_mrta.env.api import REWARD_COMPONENTS, StepInfo, StepOutput
from marl_mrta.model.schedule import EpisodeRecord, ScheduleEntry
from marl_mrta.ros.fleet_status import FleetSnapshot, RobotStatus, TaskStatus

NONE_INDEX = -1


def _indices(values: Sequence[Optional[int]]) -> List[int]:
    return [NONE_INDEX if v is None else int(v) for v in values]


def _optional_indices(values: Sequence[int]) -> List[Optional[int]]:
    return [None if v == NONE_INDEX else int(v) for v in values]


def _entry_to_message(entry: ScheduleEntry) -> ScheduleEntryMsg:
    return ScheduleEntryMsg(
        robot=entry.robot, task=entry.task, step=entry.step, start=entry.start, reached=entry.reach is not None,
        reach=0.0 if entry.reach is None else entry.reach, end=entry.end, finished=entry.finished,
        order=NONE_INDEX if entry.order is None else entry.order, logic_correct=entry.logic_correct,
        has_service_end=entry.service_end is not None,
        service_end=0.0 if entry.service_end is None else entry.service_end,
        has_service_start=entry.service_start is not None,
        service_start=0.0 if entry.service_start is None else entry.service_start)


def _entry_from_message(msg: ScheduleEntryMsg) -> ScheduleEntry:
    return ScheduleEntry(robot=int(msg.robot), task=int(msg.task), step=int(msg.step), start=msg.start,
                         reach=msg.reach if msg.reached else None, end=msg.end, finished=bool(msg.finished),
                         order=None if msg.order == NONE_INDEX else int(msg.order),
                         logic_correct=bool(msg.logic_correct),
                         service_end=msg.service_end if msg.has_service_end else None,
                         service_start=msg.service_start if msg.has_service_start else None)


def record_to_message(record: EpisodeRecord) -> EpisodeRecordMsg:
    task_finished = [t is not None for t in record.finish_time]
    return EpisodeRecordMsg(
        scenario=record.scenario, robot_ids=list(record.robot_ids), task_ids=list(record.task_ids),
        makespan=record.makespan, complete=record.complete, truncated=record.truncated,
        abort_reason=record.abort_reason, step_durations=list(record.step_durations),
        joint_actions=[a for step in record.joint_actions for a in _indices(step)],
        entries=[_entry_to_message(e) for e in record.entries], task_finished=task_finished,
        finish_time=[0.0 if t is None else t for t in record.finish_time],
        finished_by=_indices(record.finished_by),
        task_logic_correct=[bool(c) for c in record.task_logic_correct],
        nav_time=list(record.nav_time), idle_time=list(record.idle_time), collisions=list(record.collisions),
        decision_mode=record.decision_mode, task_released=[t is not None for t in record.released_at],
        released_at=[0.0 if t is None else t for t in record.released_at],
        fleet_events=[FleetEventMsg(e["time"], e["event"], e["subject"], e["detail"]) for e in record.fleet_events])


def record_from_message(msg: EpisodeRecordMsg) -> EpisodeRecord:
    n_robots = len(msg.robot_ids)
    flat = list(msg.joint_actions)
    steps = [_optional_indices(flat[k:k + n_robots]) for k in range(0, len(flat), n_robots)] if n_robots else []
    done = list(msg.task_finished)
    return EpisodeRecord(
        scenario=msg.scenario, robot_ids=list(msg.robot_ids), task_ids=list(msg.task_ids), makespan=msg.makespan,
        complete=bool(msg.complete), truncated=bool(msg.truncated), abort_reason=msg.abort_reason,
        step_durations=list(msg.step_durations), joint_actions=steps,
        entries=[_entry_from_message(e) for e in msg.entries],
        finish_time=[t if d else None for t, d in zip(msg.finish_time, done)],
        finished_by=[int(r) if d else None for r, d in zip(msg.finished_by, done)],
        task_logic_correct=[bool(c) if d else None for c, d in zip(msg.task_logic_correct, done)],
        nav_time=list(msg.nav_time), idle_time=list(msg.idle_time), collisions=[int(c) for c in msg.collisions],
        decision_mode=msg.decision_mode or "synchronous",
        released_at=[t if known else None for t, known in zip(msg.released_at, msg.task_released)],
        fleet_events=[{"time": e.time, "event": e.event, "subject": e.subject, "detail": e.detail}
                      for e in msg.fleet_events])


def info_to_message(info: StepInfo) -> StepInfoMsg:
    msg = StepInfoMsg(
        step=info.step, elapsed=info.elapsed, finished=[bool(f) for f in info.finished],
        step_duration=info.step_duration, nav_time=list(info.nav_time), idle_time=list(info.idle_time),
        collisions=[int(c) for c in info.collisions], reached=[bool(r) for r in info.reached],
        finished_task=_indices(info.finished_task), correct_order=[bool(c) for c in info.correct_order],
        failure=list(info.failure), finish_order=_indices(info.finish_order), held_time=list(info.held_time),
        has_episode=info.episode is not None, abort_reason=info.abort_reason,
        robot_tasks=_indices(info.robot_tasks), attempt_ended=[bool(e) for e in info.attempt_ended])
    if info.episode is not None:
        msg.episode = record_to_message(info.episode)
    return msg


def info_from_message(msg: StepInfoMsg) -> StepInfo:
    return StepInfo(
        step=int(msg.step), elapsed=msg.elapsed, finished=[bool(f) for f in msg.finished],
        step_duration=msg.step_duration, nav_time=list(msg.nav_time), idle_time=list(msg.idle_time),
        collisions=[int(c) for c in msg.collisions], reached=[bool(r) for r in msg.reached],
        finished_task=_optional_indices(msg.finished_task), correct_order=[bool(c) for c in msg.correct_order],
        failure=list(msg.failure), finish_order=_optional_indices(msg.finish_order), held_time=list(msg.held_time),
        episode=record_from_message(msg.episode) if msg.has_episode else None, abort_reason=msg.abort_reason,
        robot_tasks=_optional_indices(msg.robot_tasks), attempt_ended=[bool(e) for e in msg.attempt_ended])


def to_message(output: StepOutput) -> TaskEnvOutput:
    n_agents, obs_dim = output.obs.shape
    msg = TaskEnvOutput(n_agents=n_agents, obs_dim=obs_dim, n_actions=output.action_mask.shape[1])
    msg.obs = output.obs.astype(np.float32).ravel().tolist()
    msg.state = output.state.astype(np.float32).tolist()
    msg.rewards = output.rewards.astype(np.float32).tolist()
    for name in REWARD_COMPONENTS:
        setattr(msg, "reward_" + name, output.reward_components[name].astype(np.float32).tolist())
    msg.done, msg.truncated = bool(output.done), bool(output.truncated)
    msg.action_mask = output.action_mask.astype(np.uint8).ravel().tobytes()
    msg.info = info_to_message(output.info)
    if output.deciding is not None:
        msg.deciding = [bool(flag) for flag in output.deciding]
    return msg


def from_message(msg: TaskEnvOutput) -> StepOutput:
    n, d, a = msg.n_agents, msg.obs_dim, msg.n_actions
    # rospy gives uint8[] as bytes (a list of ints when the message was built by hand).
    mask = np.frombuffer(bytes(msg.action_mask), dtype=np.uint8).reshape(n, a).astype(bool)
    return StepOutput(
        obs=np.asarray(msg.obs, dtype=np.float32).reshape(n, d),
        state=np.asarray(msg.state, dtype=np.float32),
        rewards=np.asarray(msg.rewards, dtype=np.float32),
        reward_components={name: np.asarray(getattr(msg, "reward_" + name), dtype=np.float32)
                           for name in REWARD_COMPONENTS},
        done=bool(msg.done), truncated=bool(msg.truncated), action_mask=mask, info=info_from_message(msg.info),
        deciding=np.asarray(msg.deciding, dtype=bool) if len(msg.deciding) else None)


def snapshot_to_message(snapshot: FleetSnapshot, allocator: str, episode: int, stamp) -> FleetStatusMsg:
    return FleetStatusMsg(
        stamp=stamp, running=snapshot.running, allocator=allocator, episode=episode, elapsed=snapshot.elapsed,
        tasks=[TaskStatusMsg(id=t.id, category=t.category, status=t.status, robot=t.robot,
                             predecessors=list(t.predecessors), submitted=t.submitted, orphaned=t.orphaned,
                             released_at=t.released_at, start=t.start, finish=t.finish, x=t.x, y=t.y)
               for t in snapshot.tasks],
        robots=[RobotStatusMsg(id=r.id, status=r.status, task=r.task, x=r.x, y=r.y, left_reason=r.left_reason)
                for r in snapshot.robots])


def snapshot_from_message(msg: FleetStatusMsg) -> FleetSnapshot:
    return FleetSnapshot(
        running=msg.running, elapsed=msg.elapsed,
        tasks=tuple(TaskStatus(t.id, t.category, t.status, t.robot, tuple(t.predecessors), t.submitted, t.orphaned,
                               t.released_at, t.start, t.finish, t.x, t.y) for t in msg.tasks),
        robots=tuple(RobotStatus(r.id, r.status, r.task, r.x, r.y, r.left_reason) for r in msg.robots))
