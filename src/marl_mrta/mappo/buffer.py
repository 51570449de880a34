"""Rollout storage, GAE, and minibatches of whole time chunks for the recurrent actor.

Layout: time first, then environment, then robot — (T, E, N, ...). One decision step of one
environment is one "step"; its N robots are trained together so the critic's global state is
stored once per step. Episode ends split into `terminated` (all tasks reached: the return
stops there) and `truncated` (timeout/abort: the return continues with the critic's value of
the final state), following "Time Limits in Reinforcement Learning" (Pardo et al., 2018).

Event mode (env/event_env.py): a step is a decision instant at which only some robots decide
(`acting`); the others' rows are kept for the critic and for their returns, which run through
every transition (their rewards accrue while they drive), but their actions are not trained on and
their recurrent state does not advance. Each transition is discounted by its own `discount`,
γ^(Δt / discount_seconds) for its length Δt (semi-MDP returns); in synchronous mode every step
is discounted by γ and every robot acts.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np
import torch


@dataclass
class GaeResult:
    advantages: torch.Tensor   # (T, ...) GAE(γ, λ) advantages
    returns: torch.Tensor      # (T, ...) advantages + values: the critic's targets


def compute_gae(rewards: torch.Tensor, values: torch.Tensor, next_values: torch.Tensor,
                terminated: torch.Tensor, episode_end: torch.Tensor,
                gamma, gae_lambda: float) -> GaeResult:
    """GAE over time (dim 0) for any trailing shape.

    next_values[t] is the value of the state reached by step t: the next step's state inside
    an episode, the final state of a truncated episode. terminated[t] drops that bootstrap;
    episode_end[t] (terminated or truncated) stops the λ-sum from reaching into the next
    episode. terminated/episode_end broadcast against rewards (e.g. (T, E, 1) vs (T, E, N)).
    """
    bootstrap = 1.0 - terminated.to(rewards.dtype)
    carry = 1.0 - episode_end.to(rewards.dtype)
    deltas = rewards + gamma * next_values * bootstrap - values
    advantages = torch.zeros_like(rewards)
    running = torch.zeros_like(rewards[0])
    # A number: one decay for every step (computed as it always was); per step: event mode's γ^Δt.
    decay = gamma * gae_lambda if torch.is_tensor(gamma) else [gamma * gae_lambda] * rewards.shape[0]
    for t in reversed(range(rewards.shape[0])):
        running = deltas[t] + decay[t] * carry[t] * running
        advantages[t] = running
    return GaeResult(advantages=advantages, returns=advantages + values)


@dataclass
class Minibatch:
    """A set of time chunks: tensors (L, B, ...) with L the chunk length, B chunks."""

    obs: torch.Tensor            # (L, B, N, obs_in) actor inputs
    state: torch.Tensor          # (L, B, state_dim)
    actions: torch.Tensor        # (L, B, N) long
    action_mask: torch.Tensor    # (L, B, N, A) bool
    old_log_probs: torch.Tensor  # (L, B, N)
    old_values: torch.Tensor     # (L, B, N) reward units, at collection
    returns: torch.Tensor        # (L, B, N) reward units
    advantages: torch.Tensor     # (L, B, N)
    episode_start: torch.Tensor  # (L, B) bool
    actor_hidden: torch.Tensor   # (B, N, H) GRU state carried into each chunk's first step
    acting: torch.Tensor         # (L, B, N) bool: the robot decided at this step (event mode; else all)


class RolloutBuffer:
    """One batch of experience: rollout_length steps of each of n_envs environments."""

    def __init__(self, rollout_length: int, n_envs: int, n_agents: int, obs_dim: int,
                 state_dim: int, n_actions: int, hidden_size: int):
        T, E, N = rollout_length, n_envs, n_agents
        self.rollout_length, self.n_envs, self.n_agents = T, E, N
        self.obs = torch.zeros(T, E, N, obs_dim)
        self.state = torch.zeros(T, E, state_dim)
        self.actions = torch.zeros(T, E, N, dtype=torch.long)
        self.action_mask = torch.ones(T, E, N, n_actions, dtype=torch.bool)
        self.log_probs = torch.zeros(T, E, N)
        self.values = torch.zeros(T, E, N)
        self.rewards = torch.zeros(T, E, N)
        self.episode_start = torch.zeros(T, E, dtype=torch.bool)
        self.terminated = torch.zeros(T, E, dtype=torch.bool)
        self.truncated = torch.zeros(T, E, dtype=torch.bool)
        self.final_values = torch.zeros(T, E, N)
        self.actor_hidden = torch.zeros(T, E, N, hidden_size)
        self.acting = torch.ones(T, E, N, dtype=torch.bool)
        self.discounts = torch.ones(T, E, 1)
        self.advantages = torch.zeros(T, E, N)
        self.returns = torch.zeros(T, E, N)
        self.step = 0

    def insert(self, *, obs, state, actions, action_mask, log_probs, values, rewards,
               episode_start, terminated, truncated, final_values, actor_hidden, acting=None, discount=None) -> None:
        """Store one step of every environment (tensors shaped like one time slice); acting (E, N)
        and discount (E, 1): event mode's (default: every robot acts, discount 1: compute_returns's
        gamma applies)."""
        t = self.step
        assert t < self.rollout_length, "buffer full: call compute_returns() and reset()"
        for name, value in (("obs", obs), ("state", state), ("actions", actions), ("action_mask", action_mask),
                            ("log_probs", log_probs), ("values", values), ("rewards", rewards),
                            ("episode_start", episode_start), ("terminated", terminated), ("truncated", truncated),
                            ("final_values", final_values), ("actor_hidden", actor_hidden)):
            getattr(self, name)[t] = value
        self.acting[t] = True if acting is None else acting
        self.discounts[t] = 1.0 if discount is None else discount
        self.step += 1

    @property
    def full(self) -> bool:
        return self.step == self.rollout_length

    def reset(self) -> None:
        self.step = 0

    def compute_returns(self, last_values: torch.Tensor, gamma: float, gae_lambda: float,
                        per_step_discounts: bool = False) -> None:
        """Advantages and returns; last_values (E, N) = V(state after the last stored step).
        per_step_discounts: each step's stored discount (event mode) instead of gamma."""
        assert self.full, "compute_returns() needs a full buffer"
        next_values = torch.cat([self.values[1:], last_values.unsqueeze(0)])
        truncated = self.truncated.unsqueeze(-1)
        next_values = torch.where(truncated, self.final_values, next_values)
        result = compute_gae(self.rewards, self.values, next_values,
                             terminated=self.terminated.unsqueeze(-1),
                             episode_end=(self.terminated | self.truncated).unsqueeze(-1),
                             gamma=self.discounts if per_step_discounts else gamma, gae_lambda=gae_lambda)
        self.advantages, self.returns = result.advantages, result.returns

    def minibatches(self, chunk_length: int, n_minibatches: int,
                    generator: torch.Generator) -> Iterator[Minibatch]:
        """The batch cut into chunks of chunk_length steps per environment, shuffled with
        `generator` and dealt into n_minibatches groups (sizes differ by at most one)."""
        T, E = self.rollout_length, self.n_envs
        assert T % chunk_length == 0, "chunk_length must divide the rollout length"
        chunks_per_env = T // chunk_length
        n_chunks = E * chunks_per_env
        order = torch.randperm(n_chunks, generator=generator)
        for group in np.array_split(order.numpy(), n_minibatches):
            group = torch.as_tensor(group)
            env = group // chunks_per_env
            start = (group % chunks_per_env) * chunk_length
            time = start.unsqueeze(0) + torch.arange(chunk_length).unsqueeze(1)   # (L, B)
            env_tb = env.unsqueeze(0).expand_as(time)
            yield Minibatch(
                obs=self.obs[time, env_tb],
                state=self.state[time, env_tb],
                actions=self.actions[time, env_tb],
                action_mask=self.action_mask[time, env_tb],
                old_log_probs=self.log_probs[time, env_tb],
                old_values=self.values[time, env_tb],
                returns=self.returns[time, env_tb],
                advantages=self.advantages[time, env_tb],
                episode_start=self.episode_start[time, env_tb],
                actor_hidden=self.actor_hidden[start, env],
                acting=self.acting[time, env_tb],
            )
