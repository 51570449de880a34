"""Running normalisation of value targets (ValueNorm of MAPPO, Yu et al. 2022).

The critic learns returns in normalised units; GAE needs them back in reward units. Mean and
variance are exact running statistics over every target seen (parallel Welford update), kept
in float64 buffers so that they are saved and restored with the critic's state_dict.
"""
from __future__ import annotations

import torch
from torch import nn


class ValueNorm(nn.Module):
    def __init__(self, epsilon: float = 1e-5, enabled: bool = True):
        super().__init__()
        self.enabled = enabled
        self.epsilon = epsilon
        self.register_buffer("mean", torch.zeros((), dtype=torch.float64))
        self.register_buffer("var", torch.ones((), dtype=torch.float64))
        self.register_buffer("count", torch.zeros((), dtype=torch.float64))

    @torch.no_grad()
    def update(self, values: torch.Tensor) -> None:
        """Fold a batch of targets (reward units, any shape) into the running statistics."""
        if not self.enabled:
            return
        batch = values.detach().to(torch.float64).reshape(-1)
        batch_count = float(batch.numel())
        batch_mean = batch.mean()
        batch_var = batch.var(unbiased=False)
        total = self.count + batch_count
        delta = batch_mean - self.mean
        new_mean = self.mean + delta * batch_count / total
        m2 = self.var * self.count + batch_var * batch_count + delta.pow(2) * self.count * batch_count / total
        self.mean.copy_(new_mean)
        self.var.copy_(m2 / total)
        self.count.copy_(total)

    def _std(self) -> torch.Tensor:
        return torch.sqrt(self.var + self.epsilon)

    def normalize(self, values: torch.Tensor) -> torch.Tensor:
        """Reward units -> the critic's units."""
        if not self.enabled:
            return values
        return ((values.to(torch.float64) - self.mean) / self._std()).to(values.dtype)

    def denormalize(self, values: torch.Tensor) -> torch.Tensor:
        """The critic's units -> reward units."""
        if not self.enabled:
            return values
        return (values.to(torch.float64) * self._std() + self.mean).to(values.dtype)
