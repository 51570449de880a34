"""The interface every task-allocation environment offers (embedded or ROS executor).

The learner, the baselines and the evaluation command talk to environments only through
this interface, so a policy trained against one executor runs unchanged against the other.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Dict, Optional, Protocol, Sequence

import numpy as np

if TYPE_CHECKING:
    from ..scenario import Scenario

#: Names of the reward components, in the order of SPEC's reward formula.
REWARD_COMPONENTS = ("logic", "nav", "collision", "idle")


@dataclass
class StepOutput:
    """What reset() and step() return. Arrays are indexed by robot (agent) first."""

    obs: np.ndarray                      # (n_agents, obs_dim) float32, each robot's own observation
    state: np.ndarray                    # (state_dim,) float32, global state for the critic
    rewards: np.ndarray                  # (n_agents,) float32, weighted total; zeros after reset()
    reward_components: Dict[str, np.ndarray]  # name in REWARD_COMPONENTS -> (n_agents,) unweighted
    done: bool                           # episode over: all tasks reached
    truncated: bool                      # episode over: timeout (sim time) or aborted
    action_mask: np.ndarray              # (n_agents, n_actions) bool, True = allowed
    info: Dict[str, Any] = field(default_factory=dict)  # metrics, schedule record, abort reason


class TaskAllocationEnv(Protocol):
    """Algorithm 1 of the paper: one decision step = one joint action, robots navigate,
    the step ends when every robot with a goal has reached it or failed."""

    n_agents: int
    n_actions: int   # number of tasks + 1; the last action index is None (stay idle)
    obs_dim: int
    state_dim: int
    scenario: "Scenario"   # robots, tasks and their predecessors (marl_mrta.scenario)

    def reset(self, seed: Optional[int] = None) -> StepOutput: ...

    def step(self, actions: Sequence[int]) -> StepOutput: ...
