"""The schedule record of an episode (SPEC "Metrics", paper Table 6) and its summary figures.

Every method (learned policy or baseline) is scored from this record, produced by the
environment while the episode runs, so the same rules score them all.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Dict, List, Optional, Sequence

from marl_mrta.common.records import STEP_RECORD


@dataclass(**STEP_RECORD)
class ScheduleEntry:
    """One robot's attempt at one task in one decision step (slots: every step makes some, and
    every episode's record keeps them)."""

    robot: int
    task: int
    step: int
    start: float               # s since episode start: the step's start
    reach: Optional[float]     # s since episode start: arrival at the goal, None if it did not arrive
    end: float                 # s since episode start: arrival, failure or time limit
    finished: bool             # this attempt finished the task
    order: Optional[int]       # 1-based position in the global finishing order (finished attempts)
    logic_correct: bool        # every predecessor finished strictly before this arrival
    service_end: Optional[float] = None   # s since episode start: end of the service time (finished)
    service_start: Optional[float] = None  # s since episode start: its start (after any wait for predecessors)


@dataclass
class EpisodeRecord:
    scenario: str
    robot_ids: List[str]
    task_ids: List[str]
    makespan: float = 0.0                # s: episode time when it ended
    complete: bool = False               # every task finished
    truncated: bool = False              # ended by the timeout or an abort
    abort_reason: str = ""
    step_durations: List[float] = field(default_factory=list)
    joint_actions: List[List[Optional[int]]] = field(default_factory=list)   # per step: task index or None per robot
    entries: List[ScheduleEntry] = field(default_factory=list)
    finish_time: List[Optional[float]] = field(default_factory=list)     # per task
    finished_by: List[Optional[int]] = field(default_factory=list)       # per task: robot index
    task_logic_correct: List[Optional[bool]] = field(default_factory=list)  # per task, of its finishing attempt
    nav_time: List[float] = field(default_factory=list)                  # per robot, total
    idle_time: List[float] = field(default_factory=list)                 # per robot, total
    collisions: List[int] = field(default_factory=list)                  # per robot, total
    decision_mode: str = "synchronous"   # synchronous (the paper's steps) | event
    # A live fleet (env/live_fleet.py): per task, s when it became known (0: from the start; its
    # release or submission), and what changed: {time, event, subject, detail} in time order
    released_at: List[Optional[float]] = field(default_factory=list)
    fleet_events: List[Dict[str, Any]] = field(default_factory=list)

    def idle_share(self, service_times: Sequence[float]) -> float:
        """The time robots wait between their tasks (at a step's end, for predecessors, or idle),
        summed over robots, ÷ the time from the start to each robot's last finish (robots that
        finished nothing left out). 0 when no robot finished anything. service_times: per task
        (a service starts that long before its end where the entry does not say when)."""
        waited = spans = 0.0
        for robot in range(len(self.robot_ids)):
            mine = [e for e in self.entries if e.robot == robot]
            finishes = [e.service_end for e in mine if e.finished and e.service_end is not None]
            if not finishes:
                continue
            last = max(finishes)
            busy = 0.0
            for e in mine:
                if e.start >= last:
                    continue
                arrived = e.reach if e.reach is not None else e.end
                busy += max(0.0, min(arrived, last) - e.start)
                if e.finished and e.service_end is not None:
                    begun = e.service_start if e.service_start is not None else e.service_end - service_times[e.task]
                    busy += max(0.0, e.service_end - begun)
            waited += max(0.0, last - busy)
            spans += last
        return waited / spans if spans > 0 else 0.0

    @property
    def live(self) -> bool:
        """The fleet changed while it worked (a release, a request, a robot lost)."""
        return bool(self.fleet_events) or any(t not in (None, 0.0) for t in self.released_at)

    def cancelled_tasks(self) -> List[str]:
        return [e["subject"] for e in self.fleet_events if e["event"] == "cancelled"]

    @property
    def decision_steps(self) -> int:
        return len(self.step_durations)

    @property
    def logic_consistent(self) -> bool:
        """Every task finished (or cancelled, in a live fleet), each in correct order."""
        cancelled = set(self.cancelled_tasks())
        return self.complete and all(bool(flag) for task, flag in zip(self.task_ids, self.task_logic_correct)
                                     if task not in cancelled)

    def robot_task_lists(self) -> List[List[int]]:
        """Per robot, the tasks it finished, in order."""
        lists: List[List[int]] = [[] for _ in self.robot_ids]
        for entry in self.entries:
            if entry.finished:
                lists[entry.robot].append(entry.task)
        return lists

    def tasks_per_robot(self) -> List[int]:
        return [len(tasks) for tasks in self.robot_task_lists()]

    def to_dict(self) -> Dict[str, Any]:
        data = asdict(self)
        if self.decision_mode == "synchronous":   # the paper's documents, as they always were
            del data["decision_mode"]
        if not self.live:
            del data["released_at"], data["fleet_events"]
        for entry in data["entries"]:
            if entry["service_start"] is None:
                del entry["service_start"]
        data["decision_steps"] = self.decision_steps
        data["logic_consistent"] = self.logic_consistent
        data["robot_task_lists"] = [[self.task_ids[t] for t in tasks] for tasks in self.robot_task_lists()]
        data["joint_actions"] = [[None if a is None else self.task_ids[a] for a in step]
                                 for step in self.joint_actions]
        return data
