"""The PPO update of MAPPO: clipped surrogate, clipped value loss on ValueNorm targets,
entropy bonus, gradient-norm clipping, learning-rate decay.

Loss (paper Section 4.4): L = L_policy + c_v·L_value − c_e·H, averaged over robots, steps
and minibatch (the paper sums over robots; with Adam the scale of the sum does not matter).
Actor and critic have their own Adam optimiser and their own gradient-norm clip.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict

import torch
from torch import nn

from marl_mrta.mappo.buffer import Minibatch, RolloutBuffer
from marl_mrta.mappo.claims import actor_input_size, is_sequential
from marl_mrta.mappo.config import MappoConfig
from marl_mrta.mappo.networks import Actor, Critic, actor_input, log_prob_and_entropy
from marl_mrta.mappo.set_networks import SetActor, SetCritic
from marl_mrta.mappo.value_norm import ValueNorm


@dataclass
class PolicyLoss:
    policy_loss: torch.Tensor   # −E[min(r·A, clip(r, 1−ε, 1+ε)·A)]
    approx_kl: torch.Tensor     # E[(r − 1) − log r], Schulman's low-variance KL estimate
    clipfrac: torch.Tensor      # share of samples whose ratio left [1−ε, 1+ε]


def clipped_surrogate(new_log_probs: torch.Tensor, old_log_probs: torch.Tensor,
                      advantages: torch.Tensor, clip_coef: float) -> PolicyLoss:
    """PPO's clipped policy loss (Schulman et al. 2017, eq. 7) and its diagnostics."""
    log_ratio = new_log_probs - old_log_probs
    ratio = log_ratio.exp()
    unclipped = ratio * advantages
    clipped = ratio.clamp(1.0 - clip_coef, 1.0 + clip_coef) * advantages
    with torch.no_grad():
        approx_kl = ((ratio - 1.0) - log_ratio).mean()
        clipfrac = ((ratio - 1.0).abs() > clip_coef).float().mean()
    return PolicyLoss(policy_loss=-torch.min(unclipped, clipped).mean(), approx_kl=approx_kl, clipfrac=clipfrac)


def clipped_value_loss(values: torch.Tensor, old_values: torch.Tensor, targets: torch.Tensor,
                       clip_coef: float) -> torch.Tensor:
    """½·max((V − G)², (V_old + clip(V − V_old, ±c) − G)²); plain ½(V − G)² when c = 0."""
    unclipped = (values - targets).pow(2)
    if clip_coef <= 0.0:
        return 0.5 * unclipped.mean()
    moved = old_values + (values - old_values).clamp(-clip_coef, clip_coef)
    return 0.5 * torch.max(unclipped, (moved - targets).pow(2)).mean()


def explained_variance(predictions: torch.Tensor, targets: torch.Tensor) -> float:
    """1 − Var(G − V)/Var(G): 1 = perfect critic, 0 = no better than a constant."""
    variance = targets.var(unbiased=False)
    if variance.item() == 0.0:
        return float("nan")
    return float(1.0 - (targets - predictions).var(unbiased=False) / variance)


class MappoTrainer:
    """Owns the networks, the value normaliser and the optimisers; train() is one PPO update."""

    def __init__(self, config: MappoConfig, obs_dim: int, state_dim: int, n_agents: int, n_actions: int):
        self.config = config
        self.n_agents = n_agents
        self.sequential = is_sequential(config.decision_order)
        if config.actor == "set":
            # Set rows already carry the claimed flags' places and tell robots apart by their tokens.
            self.actor_obs_dim = obs_dim
            self.actor = SetActor(config.hidden_size, config.set_heads, config.set_layers)
            self.critic = SetCritic(config.hidden_size, config.set_heads, config.set_layers, n_actions - 1)
        else:
            self.actor_obs_dim = actor_input_size(obs_dim, n_actions, n_agents, config.append_agent_id,
                                                  config.decision_order)
            self.actor = Actor(self.actor_obs_dim, n_actions, config.hidden_size)
            self.critic = Critic(state_dim, n_agents, config.hidden_size, config.critic_layers)
        self.value_norm = ValueNorm(enabled=config.value_norm)
        self.actor_optimizer = torch.optim.Adam(self.actor.parameters(), lr=config.learning_rate, eps=config.adam_eps)
        self.critic_optimizer = torch.optim.Adam(self.critic.parameters(), lr=config.learning_rate, eps=config.adam_eps)

    def actor_obs(self, obs: torch.Tensor) -> torch.Tensor:
        """Environment observations (..., N, obs_dim) -> actor inputs (set rows are their own)."""
        if self.config.actor == "set":
            return obs
        return actor_input(obs, self.config.append_agent_id)

    @torch.no_grad()
    def values(self, state: torch.Tensor) -> torch.Tensor:
        """V(s) in reward units: state (..., state_dim) -> (..., N)."""
        return self.value_norm.denormalize(self.critic(state))

    def learning_rate(self, env_steps: int) -> float:
        """Staircase decay: lr · decay^⌊steps / decay_steps⌋ (the paper's 0.95 per 10 000 steps)."""
        c = self.config
        return c.learning_rate * c.lr_decay ** (env_steps // c.lr_decay_steps)

    def train(self, buffer: RolloutBuffer, env_steps: int, generator: torch.Generator,
              train_actor: bool = True) -> Dict[str, float]:
        """Epochs of minibatch updates on a buffer whose returns are computed; train_actor False:
        the critic alone (critic_warmup_updates). Returns the means over minibatches of every
        loss and diagnostic."""
        c = self.config
        lr = self.learning_rate(env_steps)
        for optimizer in (self.actor_optimizer, self.critic_optimizer):
            for group in optimizer.param_groups:
                group["lr"] = lr
        self.value_norm.update(buffer.returns)

        sums: Dict[str, float] = {}
        n_minibatches = 0
        for _ in range(c.epochs):
            epoch_kl = []
            for batch in buffer.minibatches(c.chunk_length, c.n_minibatches, generator):
                metrics = self._minibatch_step(batch, train_actor)
                epoch_kl.append(metrics["approx_kl"])
                for key, value in metrics.items():
                    sums[key] = sums.get(key, 0.0) + value
                n_minibatches += 1
            if c.target_kl > 0.0 and sum(epoch_kl) / len(epoch_kl) > c.target_kl:
                break
        metrics = {key: value / n_minibatches for key, value in sums.items()}
        metrics["explained_variance"] = explained_variance(buffer.values, buffer.returns)
        metrics["learning_rate"] = lr
        metrics["epochs_run"] = float(n_minibatches // c.n_minibatches)
        return metrics

    def _minibatch_step(self, batch: Minibatch, train_actor: bool = True) -> Dict[str, float]:
        c = self.config
        L, B, N = batch.actions.shape
        acting = batch.acting.reshape(L, B * N)
        everyone = bool(acting.all())   # synchronous mode: every robot decides every step
        actor_out = self.actor(
            batch.obs.reshape(L, B * N, -1),
            batch.actor_hidden.reshape(B * N, -1),
            batch.episode_start.unsqueeze(-1).expand(L, B, N).reshape(L, B * N),
            batch.action_mask.reshape(L, B * N, -1),
            *(() if everyone else (acting,)),
        )
        new_log_probs, entropy = log_prob_and_entropy(actor_out.logits, batch.actions.reshape(L, B * N))
        advantages = batch.advantages.reshape(L, B * N)
        old_log_probs = batch.old_log_probs.reshape(L, B * N)
        if not everyone:   # event mode: only the decisions taken are trained on
            new_log_probs, entropy = new_log_probs[acting], entropy[acting]
            advantages, old_log_probs = advantages[acting], old_log_probs[acting]
        if c.normalize_advantages:
            advantages = (advantages - advantages.mean()) / (advantages.std(unbiased=False) + 1e-8)
        policy = clipped_surrogate(new_log_probs, old_log_probs, advantages, c.clip_coef)
        entropy_mean = entropy.mean()

        values = self.critic(batch.state)                         # (L, B, N), normalised units
        targets = self.value_norm.normalize(batch.returns)
        old_values = self.value_norm.normalize(batch.old_values)
        value_loss = clipped_value_loss(values, old_values, targets, c.value_clip_coef)

        loss = policy.policy_loss - c.entropy_coef * entropy_mean + c.value_coef * value_loss
        self.actor_optimizer.zero_grad(set_to_none=True)
        self.critic_optimizer.zero_grad(set_to_none=True)
        (loss if train_actor else c.value_coef * value_loss).backward()
        actor_grad_norm = nn.utils.clip_grad_norm_(self.actor.parameters(), c.max_grad_norm) if train_actor \
            else torch.zeros(())
        critic_grad_norm = nn.utils.clip_grad_norm_(self.critic.parameters(), c.max_grad_norm)
        if train_actor:
            self.actor_optimizer.step()
        self.critic_optimizer.step()
        return {
            "loss": float(loss.detach()),
            "policy_loss": float(policy.policy_loss.detach()),
            "value_loss": float(value_loss.detach()),
            "entropy": float(entropy_mean.detach()),
            "approx_kl": float(policy.approx_kl),
            "clipfrac": float(policy.clipfrac),
            "grad_norm": float(actor_grad_norm),
            "critic_grad_norm": float(critic_grad_norm),
        }

    def state_dict(self) -> Dict[str, object]:
        return {
            "actor": self.actor.state_dict(),
            "critic": self.critic.state_dict(),
            "value_norm": self.value_norm.state_dict(),
            "actor_optimizer": self.actor_optimizer.state_dict(),
            "critic_optimizer": self.critic_optimizer.state_dict(),
        }

    def load_state_dict(self, state: Dict[str, object]) -> None:
        self.actor.load_state_dict(state["actor"])
        self.critic.load_state_dict(state["critic"])
        self.value_norm.load_state_dict(state["value_norm"])
        self.actor_optimizer.load_state_dict(state["actor_optimizer"])
        self.critic_optimizer.load_state_dict(state["critic_optimizer"])
