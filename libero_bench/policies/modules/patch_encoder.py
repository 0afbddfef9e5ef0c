"""Patch tokens for ViT-T: a stride-2 convolutional stem, then a linear projection per patch."""

from __future__ import annotations

from torch import Tensor, nn


class PatchEncoder(nn.Module):
    """(N, 3, H, W) -> (N, P, E) with P = (H / 2 / patch)^2 tokens."""

    def __init__(self, image_size: int, patch_size: int = 8, embed_dim: int = 128, stem_channels: int = 64):
        super().__init__()
        if image_size % (2 * patch_size) != 0:
            raise ValueError(f"image_size {image_size} must be a multiple of 2 * patch_size")
        self.stem = nn.Sequential(
            nn.Conv2d(3, stem_channels, 7, 2, 3, bias=False), nn.BatchNorm2d(stem_channels), nn.ReLU()
        )
        self.project = nn.Conv2d(stem_channels, embed_dim, patch_size, patch_size)
        self.norm = nn.BatchNorm2d(embed_dim)
        self.grid = image_size // 2 // patch_size
        self.num_patches = self.grid * self.grid

    def forward(self, images: Tensor) -> Tensor:
        h = self.norm(self.project(self.stem(images)))
        return h.flatten(2).transpose(1, 2)
