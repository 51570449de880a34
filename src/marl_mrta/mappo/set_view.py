"""Environments and observations as the set actor sees them (`actor: set`).

SetView reads one scenario's observation rows as sets (env/observation.py): it is what a robot
running a set actor needs besides its own row, namely the scenario and its nominal travel-time
table. SetViewEnv is an environment (env/api.py) whose observations, state and masks are already
in that form, padded to fixed robot and task slots, so that the environments of one pool, each
possibly running another scenario (training across scenarios), share the buffer's shapes:
- observations: each robot's set row; a padded robot slot is all zeros;
- state: the set critic's global state (SetLayout.state_width);
- masks: the scenario's tasks, closed padded task slots, None last; a padded robot may only
  choose None; its reward is the team mean, so the team reward is that of the real robots;
- actions: None (the last slot) becomes the scenario's None; padded robots' actions are dropped.
With several scenarios, episode k of the environment runs scenario `choose(seed)` of its list,
so a run stays a function of its seeds (replay on resume rebuilds the same episodes).
"""
from __future__ import annotations

import copy
import dataclasses
from typing import Callable, Dict, Optional, Sequence, Tuple

import numpy as np
import torch

from marl_mrta.env.api import StepOutput, TaskAllocationEnv
from marl_mrta.env.factory import scenario_travel_table
from marl_mrta.env.observation import ObservationEncoder, SetLayout, SetObservationEncoder
from marl_mrta.mappo.claims import turns_from_rows
from marl_mrta.model.scenario import Scenario


class SetView:
    """One scenario's observation rows -> set rows (the nominal travel table is planned once)."""

    def __init__(self, scenario: Scenario, turn_order: str = "index"):
        """turn_order: how the robots take turns when deciding in sequence (env/observation.py)."""
        table = scenario_travel_table(scenario)
        self.scenario = scenario
        self.flat = ObservationEncoder(scenario)
        self.encoder = SetObservationEncoder(self.flat, scenario, table.nominal_time, table.node_poses, turn_order)
        self.layout = SetLayout(scenario.n_robots, scenario.n_tasks)

    def turned(self, orientation: int) -> "SetView":
        """This view with the floor turned (env/observation.py, ORIENTATIONS; 0: as it is)."""
        view = copy.copy(self)
        view.encoder = self.encoder.turned(orientation)
        return view

    def rows(self, obs: np.ndarray, robots: Sequence[int], sequential: bool,
             layout: Optional[SetLayout] = None) -> np.ndarray:
        """Set rows (k, width) of observation rows (k, obs_dim) of robots `robots`."""
        if np.asarray(obs).shape[-1] != self.flat.obs_dim:
            raise ValueError(f"observation of {np.asarray(obs).shape[-1]} values, scenario {self.scenario.name} "
                             f"has {self.flat.obs_dim}")
        return self.encoder.encode(obs, robots, layout or self.layout, sequential)

    def turns(self, obs: np.ndarray) -> torch.Tensor:
        """The robots in the order they choose (n,) long, from every robot's observation row (n, obs_dim)."""
        return turns_from_rows(torch.as_tensor(self.rows(obs, range(len(obs)), True)), self.scenario.n_tasks)


def slot_mask(mask: np.ndarray, robot_slots: int, task_slots: int) -> np.ndarray:
    """A scenario's masks (n_robots, n_tasks + 1) in slots (robot_slots, task_slots + 1): padded
    tasks closed, None last, padded robots with None alone."""
    n, m = mask.shape[0], mask.shape[1] - 1
    out = np.zeros((robot_slots, task_slots + 1), dtype=bool)
    out[:n, :m] = mask[:, :m]
    out[:, task_slots] = True
    out[:n, task_slots] = mask[:, m]
    return out


class SetViewEnv:
    """Implements env.api.TaskAllocationEnv over one or several scenarios' environments (module doc)."""

    def __init__(self, build: Callable[[int], TaskAllocationEnv], n_scenarios: int, robot_slots: int,
                 task_slots: int, sequential: bool, choose: Optional[Callable[[int], int]] = None,
                 turn_order: str = "index"):
        """build(i): the environment of scenario i (built once, on first use); choose(seed): the
        scenario of an episode reset with `seed` (default: seed mod n_scenarios); turn_order: as SetView's."""
        self.build = build
        self.n_scenarios = n_scenarios
        self.choose = choose or (lambda seed: seed % n_scenarios)
        self.sequential = sequential
        self.turn_order = turn_order
        self.layout = SetLayout(robot_slots, task_slots)
        self.n_agents, self.n_actions = robot_slots, task_slots + 1
        self.obs_dim, self.state_dim = self.layout.width, self.layout.state_width()
        self._built: Dict[int, Tuple[TaskAllocationEnv, SetView]] = {}
        self.current = 0
        self.env, self.view = self._scenario(0)

    @property
    def scenario(self) -> Scenario:
        """The scenario of the running episode."""
        return self.env.scenario

    def _scenario(self, index: int) -> Tuple[TaskAllocationEnv, SetView]:
        if index not in self._built:
            env = self.build(index)
            if env.n_agents > self.n_agents or env.n_actions > self.n_actions:
                raise ValueError(f"scenario {env.scenario.name}: {env.n_agents} robots and {env.n_actions - 1} tasks "
                                 f"do not fit {self.n_agents} robot and {self.n_actions - 1} task slots")
            self._built[index] = (env, SetView(env.scenario, self.turn_order))
        return self._built[index]

    def reset(self, seed: Optional[int] = None) -> StepOutput:
        if seed is not None and self.n_scenarios > 1:
            self.current = self.choose(int(seed))
            self.env, self.view = self._scenario(self.current)
        return self._output(self.env.reset(seed=seed))

    def step(self, actions: Sequence[int]) -> StepOutput:
        n, none = self.env.n_agents, self.env.n_actions - 1
        joint = [none if int(a) == self.n_actions - 1 else int(a) for a in list(actions)[:n]]
        return self._output(self.env.step(joint))

    def _output(self, out: StepOutput) -> StepOutput:
        n = self.env.n_agents
        rows = self.view.rows(out.obs, range(n), self.sequential, self.layout)
        obs = np.zeros((self.n_agents, self.obs_dim), dtype=np.float32)
        obs[:n] = rows
        deciding = None
        if out.deciding is not None:   # event mode: padded robots never decide and hold no task
            deciding = np.zeros(self.n_agents, dtype=bool)
            deciding[:n] = out.deciding
            out.info.robot_tasks = list(out.info.robot_tasks) + [None] * (self.n_agents - n)
        return dataclasses.replace(
            out, obs=obs, state=self.view.encoder.state(rows, self.layout),
            rewards=self._pad(out.rewards), reward_components={k: self._pad(v) for k, v in out.reward_components.items()},
            action_mask=slot_mask(np.asarray(out.action_mask, dtype=bool), self.n_agents, self.n_actions - 1),
            deciding=deciding)

    def _pad(self, values: np.ndarray) -> np.ndarray:
        """Per robot values with padded robots given the mean of the real ones (the team's)."""
        values = np.asarray(values, dtype=np.float32)
        out = np.full(self.n_agents, values.mean() if len(values) else 0.0, dtype=np.float32)
        out[:len(values)] = values
        return out

