"""Small MLPs: language projection and one token per low-dimensional state modality."""

from __future__ import annotations

import torch
from torch import Tensor, nn

from libero_bench.data.batch_keys import GRIPPER_DIM, JOINT_DIM


def mlp(input_dim: int, hidden_dim: int, output_dim: int, num_layers: int = 1) -> nn.Sequential:
    """``num_layers`` linear layers with ReLU between them (1 layer = a linear map)."""
    if num_layers < 1:
        raise ValueError(f"num_layers must be >= 1, got {num_layers}")
    widths = [input_dim] + [hidden_dim] * (num_layers - 1) + [output_dim]
    layers: list[nn.Module] = []
    for i in range(num_layers):
        layers.append(nn.Linear(widths[i], widths[i + 1]))
        if i < num_layers - 1:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class LowDimTokens(nn.Module):
    """Joint (7) and gripper (2) states -> two tokens (B, T, 2, D), one linear map each
    (the extra-modality encoder of the transformer policies)."""

    def __init__(self, token_dim: int) -> None:
        super().__init__()
        self.joint = nn.Linear(JOINT_DIM, token_dim)
        self.gripper = nn.Linear(GRIPPER_DIM, token_dim)

    def forward(self, joint_states: Tensor, gripper_states: Tensor) -> Tensor:
        return torch.stack([self.joint(joint_states), self.gripper(gripper_states)], dim=-2)
