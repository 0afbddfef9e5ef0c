"""Synthetic batches for the libero_bench tests (imported by tests and conftest)."""

from __future__ import annotations

from collections.abc import Callable

import torch

BatchFactory = Callable[..., dict[str, torch.Tensor]]


def synthetic_batch(
    batch_size: int = 2,
    window: int = 4,
    image_size: int = 32,
    task_emb_dim: int = 384,
    seed: int = 0,
    task_id: int = 0,
) -> dict[str, torch.Tensor]:
    """A batch with the trainer's keys, shapes and value ranges."""
    g = torch.Generator().manual_seed(seed)
    b, t, s = batch_size, window, image_size
    return {
        "agentview": torch.rand(b, t, 3, s, s, generator=g),
        "wrist": torch.rand(b, t, 3, s, s, generator=g),
        "joint_states": torch.randn(b, t, 7, generator=g),
        "gripper_states": torch.randn(b, t, 2, generator=g) * 0.04,
        "task_emb": torch.randn(b, task_emb_dim, generator=g),
        "actions": torch.rand(b, t, 7, generator=g) * 2 - 1,
        "task_id": torch.full((b,), task_id, dtype=torch.long),
    }
