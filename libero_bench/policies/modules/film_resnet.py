"""ResNet-like image encoder with FiLM language conditioning and a spatial-softmax projection.

The layout follows the first two stages of ResNet-18 (stem, 2 + 2 basic blocks), which is
what the LIBERO ResNet policies keep; a FiLM layer after every block scales and shifts the
feature maps with a linear function of the task embedding.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn


class BasicBlock(nn.Module):
    """Two 3x3 convolutions with batch norm and a residual connection."""

    def __init__(self, in_channels: int, out_channels: int, stride: int = 1) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(in_channels, out_channels, 3, stride, 1, bias=False)
        self.bn1 = nn.BatchNorm2d(out_channels)
        self.conv2 = nn.Conv2d(out_channels, out_channels, 3, 1, 1, bias=False)
        self.bn2 = nn.BatchNorm2d(out_channels)
        self.shortcut: nn.Module = nn.Identity()
        if stride != 1 or in_channels != out_channels:
            self.shortcut = nn.Sequential(
                nn.Conv2d(in_channels, out_channels, 1, stride, bias=False), nn.BatchNorm2d(out_channels)
            )

    def forward(self, x: Tensor) -> Tensor:
        h = F.relu(self.bn1(self.conv1(x)))
        h = self.bn2(self.conv2(h))
        return F.relu(h + self.shortcut(x))


class SpatialSoftmax(nn.Module):
    """Keypoints as softmax-weighted image coordinates: (N, C, H, W) -> (N, 2 * K)."""

    grid: Tensor

    def __init__(self, channels: int, height: int, width: int, num_keypoints: int) -> None:
        super().__init__()
        self.num_keypoints = num_keypoints
        self.to_keypoints: nn.Module = (
            nn.Identity() if num_keypoints == channels else nn.Conv2d(channels, num_keypoints, 1)
        )
        ys, xs = torch.meshgrid(torch.linspace(-1, 1, height), torch.linspace(-1, 1, width), indexing="ij")
        self.register_buffer("grid", torch.stack([xs.flatten(), ys.flatten()], dim=-1), persistent=False)

    def forward(self, x: Tensor) -> Tensor:
        attention = torch.softmax(self.to_keypoints(x).flatten(2), dim=-1)  # (N, K, HW)
        return (attention @ self.grid).flatten(1)  # (N, 2K)


def _conv_out(size: int, kernel: int, stride: int, padding: int) -> int:
    return (size + 2 * padding - kernel) // stride + 1


class FiLMResNetEncoder(nn.Module):
    """(N, 3, H, W) images in [0, 1] (+ task embeddings (N, E)) -> (N, out_dim) latents."""

    def __init__(
        self,
        image_size: int,
        out_dim: int,
        lang_dim: int,
        channels: tuple[int, int] = (64, 128),
        film: bool = True,
    ) -> None:
        super().__init__()
        c1, c2 = channels
        self.stem = nn.Sequential(
            nn.Conv2d(3, c1, 7, 2, 3, bias=False),
            nn.BatchNorm2d(c1),
            nn.ReLU(),
            nn.MaxPool2d(3, 2, 1),
        )
        self.blocks = nn.ModuleList(
            [BasicBlock(c1, c1), BasicBlock(c1, c1), BasicBlock(c1, c2, stride=2), BasicBlock(c2, c2)]
        )
        self.film = nn.ModuleList([nn.Linear(lang_dim, 2 * c) for c in (c1, c1, c2, c2)]) if film else None
        side = _conv_out(_conv_out(_conv_out(image_size, 7, 2, 3), 3, 2, 1), 3, 2, 1)
        num_keypoints = max(1, out_dim // 2)
        self.keypoints = SpatialSoftmax(c2, side, side, num_keypoints)
        self.projection = nn.Linear(2 * num_keypoints, out_dim)

    def forward(self, images: Tensor, lang: Tensor | None = None) -> Tensor:
        h = self.stem(images)
        for i, block in enumerate(self.blocks):
            h = block(h)
            if self.film is not None and lang is not None:
                gamma, beta = self.film[i](lang).chunk(2, dim=-1)
                h = h * (1.0 + gamma[..., None, None]) + beta[..., None, None]
        return self.projection(self.keypoints(h))
