"""Gaussian-mixture action head (5 modes in the paper) and its deterministic action."""

from __future__ import annotations

from typing import cast

import torch
import torch.nn.functional as F
from torch import Tensor, nn
from torch.distributions import Categorical, Independent, MixtureSameFamily, Normal


class GMMHead(nn.Module):
    """Maps features (..., D) to a mixture of diagonal Gaussians over actions (..., A).

    Means are squashed with tanh (actions live in [-1, 1]); scales are softplus + ``min_std``.
    """

    def __init__(
        self,
        input_dim: int,
        action_dim: int,
        hidden_dim: int = 1024,
        num_layers: int = 2,
        num_modes: int = 5,
        min_std: float = 1e-4,
    ) -> None:
        super().__init__()
        self.action_dim = action_dim
        self.num_modes = num_modes
        self.min_std = min_std
        layers: list[nn.Module] = []
        width = input_dim
        for _ in range(num_layers):
            layers += [nn.Linear(width, hidden_dim), nn.ReLU()]
            width = hidden_dim
        self.trunk = nn.Sequential(*layers)
        self.mean = nn.Linear(width, num_modes * action_dim)
        self.scale = nn.Linear(width, num_modes * action_dim)
        self.logits = nn.Linear(width, num_modes)

    def forward(self, features: Tensor) -> MixtureSameFamily:
        h = self.trunk(features)
        shape = (*features.shape[:-1], self.num_modes, self.action_dim)
        means = torch.tanh(self.mean(h)).view(shape)
        stds = F.softplus(self.scale(h)).view(shape) + self.min_std
        components = Independent(Normal(means, stds), 1)
        return MixtureSameFamily(Categorical(logits=self.logits(h)), components)


def gmm_mode_mean(dist: MixtureSameFamily) -> Tensor:
    """The mean of the most likely mode: a deterministic action of shape (..., A)."""
    logits = cast(Tensor, dist.mixture_distribution.logits)
    components = cast(Independent, dist.component_distribution)
    means = cast(Tensor, components.base_dist.mean)  # (..., M, A)
    best = logits.argmax(dim=-1)
    index = best[..., None, None].expand(*best.shape, 1, means.shape[-1])
    return means.gather(-2, index).squeeze(-2)
