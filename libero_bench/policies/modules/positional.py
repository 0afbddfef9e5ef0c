"""Sinusoidal position encoding over timesteps."""

from __future__ import annotations

import torch
from torch import Tensor, nn


class SinusoidalPositionEncoding(nn.Module):
    """``forward(length)`` -> (length, dim): [sin(p * f), cos(p * f)] with f = base^(-2i/dim).

    LIBERO uses a small base (10) because the windows are short (10 steps).
    """

    inv_freq: Tensor

    def __init__(self, dim: int, base: float = 10.0) -> None:
        super().__init__()
        self.dim = dim
        even = dim + dim % 2
        inv_freq = 1.0 / (base ** (torch.arange(0, even, 2, dtype=torch.float32) / even))
        self.register_buffer("inv_freq", inv_freq, persistent=False)

    def forward(self, length: int) -> Tensor:
        inv_freq = self.inv_freq
        positions = torch.arange(length, device=inv_freq.device, dtype=inv_freq.dtype)
        angles = positions[:, None] * inv_freq[None, :]
        return torch.cat([angles.sin(), angles.cos()], dim=-1)[:, : self.dim]
