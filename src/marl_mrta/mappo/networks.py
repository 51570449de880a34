"""The two networks of MAPPO under CTDE.

Actor: shared by all robots, recurrent (GRU), sees one robot's observation (plus, optionally,
its one-hot index) and gives logits over tasks + None; masked actions get probability zero.
Critic: training only, an MLP on the global state giving one value per robot.

The GRU's hidden state is zeroed *before* the step whose observation starts an episode, in
exactly one place (`Actor.forward`), so collection and training see the same recurrence.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np
import torch
from torch import nn


def layer_init(layer: nn.Linear, gain: float = float(np.sqrt(2.0))) -> nn.Linear:
    """Orthogonal weights, zero bias (PPO practice: CleanRL, MAPPO)."""
    nn.init.orthogonal_(layer.weight, gain)
    nn.init.zeros_(layer.bias)
    return layer


def masked_logits(logits: torch.Tensor, action_mask: Optional[torch.Tensor]) -> torch.Tensor:
    """Logits with disallowed actions (mask False) set to the lowest float: probability 0."""
    if action_mask is None:
        return logits
    return logits.masked_fill(~action_mask, torch.finfo(logits.dtype).min)


def gru_cell(width: int) -> nn.GRUCell:
    """The actors' recurrent cell: orthogonal weights, zero biases."""
    cell = nn.GRUCell(width, width)
    for name, param in cell.named_parameters():
        if "weight" in name:
            nn.init.orthogonal_(param)
        else:
            nn.init.zeros_(param)
    return cell


@dataclass
class ActorOutput:
    """Actor result for a batch of (sequence of) robot observations."""

    logits: torch.Tensor   # (..., n_actions), already masked
    hidden: torch.Tensor   # (batch, hidden_size) GRU state after the last step


class Actor(nn.Module):
    """πθ(a | o_i): encoder MLP → GRU cell → linear logits, parameters shared by all robots."""

    def __init__(self, obs_dim: int, n_actions: int, hidden_size: int):
        super().__init__()
        self.obs_dim = obs_dim
        self.n_actions = n_actions
        self.hidden_size = hidden_size
        self.encoder = nn.Sequential(
            nn.LayerNorm(obs_dim),
            layer_init(nn.Linear(obs_dim, hidden_size)), nn.ReLU(),
            layer_init(nn.Linear(hidden_size, hidden_size)), nn.ReLU(),
        )
        self.gru = gru_cell(hidden_size)
        self.gru_norm = nn.LayerNorm(hidden_size)
        # Small gain: near-uniform initial policy (CleanRL, "37 implementation details").
        self.head = layer_init(nn.Linear(hidden_size, n_actions), gain=0.01)

    def initial_hidden(self, batch: int) -> torch.Tensor:
        return torch.zeros(batch, self.hidden_size)

    def forward(self, obs: torch.Tensor, hidden: torch.Tensor, episode_start: torch.Tensor,
                action_mask: Optional[torch.Tensor] = None, acting: Optional[torch.Tensor] = None) -> ActorOutput:
        """Run a sequence. obs (T, B, obs_dim), hidden (B, H) before step 0, episode_start
        (T, B) bool: True where obs[t] is the first observation of an episode, so the state
        carried into step t is zeroed. action_mask (T, B, n_actions) bool or None. acting (T, B)
        bool (event mode): where False the robot does not decide at step t and its state carries
        over unchanged (its logits there are not used)."""
        features = self.encoder(obs)
        outputs = []
        for t in range(obs.shape[0]):
            hidden = hidden * (~episode_start[t]).unsqueeze(-1).to(hidden.dtype)
            stepped = self.gru(features[t], hidden)
            outputs.append(stepped)
            hidden = stepped if acting is None else torch.where(acting[t].unsqueeze(-1), stepped, hidden)
        logits = self.head(self.gru_norm(torch.stack(outputs)))
        mask = None if action_mask is None else action_mask
        return ActorOutput(logits=masked_logits(logits, mask), hidden=hidden)


class Critic(nn.Module):
    """V_φ(s): MLP on the global state, one value per robot (in ValueNorm's units)."""

    def __init__(self, state_dim: int, n_agents: int, hidden_size: int, n_layers: int):
        super().__init__()
        layers = [nn.LayerNorm(state_dim)]
        width = state_dim
        for _ in range(n_layers):
            layers += [layer_init(nn.Linear(width, hidden_size)), nn.ReLU()]
            width = hidden_size
        layers.append(layer_init(nn.Linear(width, n_agents), gain=1.0))
        self.net = nn.Sequential(*layers)

    def forward(self, state: torch.Tensor) -> torch.Tensor:
        """state (..., state_dim) -> values (..., n_agents)."""
        return self.net(state)


def actor_input(obs: torch.Tensor, append_agent_id: bool) -> torch.Tensor:
    """obs (..., n_agents, obs_dim) with the one-hot robot index appended when asked."""
    if not append_agent_id:
        return obs
    n_agents = obs.shape[-2]
    one_hot = torch.eye(n_agents, dtype=obs.dtype).expand(*obs.shape[:-2], n_agents, n_agents)
    return torch.cat([obs, one_hot], dim=-1)


def log_prob_and_entropy(logits: torch.Tensor, actions: torch.Tensor):
    """log π(a) of the taken actions and the policy entropy, both shaped like `actions`.
    Masked actions (logit = lowest float) contribute nothing to the entropy."""
    log_probs = torch.log_softmax(logits, dim=-1)
    probs = log_probs.exp()
    taken = log_probs.gather(-1, actions.long().unsqueeze(-1)).squeeze(-1)
    entropy = -(probs * log_probs.clamp(min=torch.finfo(log_probs.dtype).min)).sum(-1)
    return taken, entropy


def sample_actions(logits: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
    """One action per row of `logits` (..., n_actions), drawn with the given generator so
    that sampling is reproducible independently of any other use of torch's global RNG."""
    probs = torch.softmax(logits, dim=-1)
    flat = torch.multinomial(probs.reshape(-1, probs.shape[-1]), 1, generator=generator)
    return flat.reshape(probs.shape[:-1])
