"""The interface every task-allocation environment offers (embedded or ROS executor).

The learner, the baselines and the evaluation command talk to environments only through
this interface, so a policy trained against one executor runs unchanged against the other.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Protocol, Sequence

import numpy as np

from marl_mrta.model.scenario import Scenario
from marl_mrta.model.schedule import EpisodeRecord
from marl_mrta.common.records import STEP_RECORD

#: Names of the reward components, in the order of SPEC's reward formula.
REWARD_COMPONENTS = ("logic", "nav", "collision", "idle")


@dataclass(**STEP_RECORD)
class StepInfo:
    """What happened in the step just taken (after reset(): step 0, nothing done). Per-robot
    lists are indexed by robot and empty after reset(). Slots: one is made every step."""

    step: int                                   # decision steps taken in this episode
    elapsed: float                              # s of episode time
    finished: List[bool]                        # per task: finished by now
    step_duration: float = 0.0                  # s
    nav_time: List[float] = field(default_factory=list)         # s navigated
    idle_time: List[float] = field(default_factory=list)        # s waited for the step to end
    collisions: List[int] = field(default_factory=list)         # collision events
    reached: List[bool] = field(default_factory=list)           # arrived at its goal
    finished_task: List[Optional[int]] = field(default_factory=list)   # task this robot finished, or None
    correct_order: List[bool] = field(default_factory=list)     # its attempt respected the precedence
    failure: List[str] = field(default_factory=list)            # why its navigation failed ("" if not)
    finish_order: List[Optional[int]] = field(default_factory=list)    # 1-based finishing position, or None
    held_time: List[float] = field(default_factory=list)        # s waited at its task for predecessors
    episode: Optional[EpisodeRecord] = None     # the schedule record, on the episode's last step
    abort_reason: str = ""                      # why the episode was aborted ("" if it was not)
    # Event mode: per robot, the task it drives to, holds at or serves (None: idle). A policy that
    # decides in turn takes those of busy robots as claimed.
    robot_tasks: List[Optional[int]] = field(default_factory=list)
    # Event mode: per robot, its attempt at a task ended in this transition (finished_task says
    # whether it finished it; nav_time is that attempt's); idle_time is what it waited in it.
    attempt_ended: List[bool] = field(default_factory=list)


@dataclass(**STEP_RECORD)
class StepOutput:
    """What reset() and step() return. Arrays are indexed by robot (agent) first."""

    obs: np.ndarray                      # (n_agents, obs_dim) float32, each robot's own observation
    state: np.ndarray                    # (state_dim,) float32, global state for the critic
    rewards: np.ndarray                  # (n_agents,) float32, weighted total; zeros after reset()
    reward_components: Dict[str, np.ndarray]  # name in REWARD_COMPONENTS -> (n_agents,) unweighted
    done: bool                           # episode over: all tasks reached
    truncated: bool                      # episode over: timeout (sim time) or aborted
    action_mask: np.ndarray              # (n_agents, n_actions) bool, True = allowed
    info: StepInfo
    # (n_agents,) bool: the robots that decide now. None in synchronous mode (every robot, every
    # step); in event mode the others' actions are ignored (their mask rows allow None alone).
    deciding: Optional[np.ndarray] = None


class TaskAllocationEnv(Protocol):
    """Algorithm 1 of the paper: one decision step = one joint action, robots navigate,
    the step ends when every robot with a goal has reached it or failed (decision_mode
    synchronous); or (event) a step ends when a robot comes free, and only the robots in
    StepOutput.deciding decide at it."""

    n_agents: int
    n_actions: int   # number of tasks + 1; the last action index is None (stay idle)
    obs_dim: int
    state_dim: int
    scenario: Scenario     # robots, tasks and their predecessors (marl_mrta.model.scenario)

    def reset(self, seed: Optional[int] = None) -> StepOutput: ...

    def step(self, actions: Sequence[int]) -> StepOutput: ...


class Policy(Protocol):
    """A decision maker of whole episodes (baselines, plans, learned actors, the robots' own
    actors): the one interface the episode loop (evaluation/loop.py) drives."""

    name: str

    def begin_episode(self, first: StepOutput, episode: Optional[int] = None) -> None:
        """A new episode starts with `first` (what reset() returned); episode: its index in the run."""

    def act(self, output: StepOutput) -> List[int]:
        """One action per robot: a task index, or n_tasks for None."""
