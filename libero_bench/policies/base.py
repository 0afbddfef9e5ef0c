"""The policy interface every registered policy implements (the registry of their configs is
``libero_bench.policies.config_base.POLICY_CONFIGS``).

A policy splits into a per-frame encoder (``encode_frames``: frames are encoded
independently), a temporal model over the window (``temporal``) and a GMM head. The base
class turns these into the public API:

- ``forward(batch)`` -> a ``MixtureSameFamily`` over actions with batch shape (B, T);
  ``log_prob(batch["actions"])`` is (B, T)
- ``loss(batch)`` -> mean negative log-likelihood (training-time augmentation applies when
  the module is in training mode and the config enables it)
- ``act(batch)`` -> (B, A): deterministic action (mean of the most likely mode) for the
  last frame of the given window; stateless
- ``act_step(batch)`` -> (B, A): the same for a single new frame (T = 1), keeping history
  inside the policy (frame latents for the transformers, the LSTM state for ResNet-RNN)
  until ``reset()``; call ``reset()`` at the start of every episode
- ``visual_latent(images (B, 3, H, W), task_emb (B, E))`` -> (B, D): the agentview visual
  encoder's latent (for saliency maps)
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Any, ClassVar, Self

import torch
from torch import Tensor, nn
from torch.distributions import MixtureSameFamily

from libero_bench.data.batch_keys import (
    ACTIONS,
    AGENTVIEW,
    GRIPPER_DIM,
    GRIPPER_STATES,
    IMAGE_KEYS,
    JOINT_DIM,
    JOINT_STATES,
    TASK_EMB,
    WRIST,
)
from libero_bench.policies.config_base import PolicyConfig
from libero_bench.policies.modules.augment import augment_images
from libero_bench.policies.modules.gmm import GMMHead, gmm_mode_mean

Batch = Mapping[str, Tensor]


@contextmanager
def eval_mode(module: nn.Module) -> Iterator[None]:
    """Temporarily switch ``module`` (and its children) to eval mode."""
    modes = {m: m.training for m in module.modules()}
    module.eval()
    try:
        yield
    finally:
        for m, mode in modes.items():
            m.training = mode


class Policy(nn.Module):
    """Base class of the LIBERO policies (see the module docstring for the API)."""

    config_class: ClassVar[type[PolicyConfig]] = PolicyConfig
    head: GMMHead

    def __init__(self, config: PolicyConfig) -> None:
        super().__init__()
        if not isinstance(config, self.config_class):
            raise TypeError(
                f"{type(self).__name__} needs a {self.config_class.__name__}, got {type(config).__name__}"
            )
        self.config = config

    @classmethod
    def from_config(cls, config: PolicyConfig) -> Self:
        return cls(config)

    # -- to implement ------------------------------------------------------------------------
    def encode_frames(self, batch: Batch) -> Tensor:
        """Per-frame features (B, T, ...), each frame encoded independently of the others."""
        raise NotImplementedError

    def temporal(self, frames: Tensor) -> Tensor:
        """Window features (B, T, D) from ``encode_frames`` output, causal in time."""
        raise NotImplementedError

    def temporal_step(self, frames: Tensor) -> Tensor:
        """Features (B, D) of one new frame (B, 1, ...), using the history kept since ``reset``."""
        raise NotImplementedError

    def reset(self) -> None:
        """Forget the history kept by ``act_step``."""

    def visual_latent(self, images: Tensor, task_emb: Tensor) -> Tensor:
        """Latent (B, D) of the agentview encoder for images (B, 3, H, W)."""
        raise NotImplementedError

    # -- shared API -----------------------------------------------------------------------
    def check_batch(self, batch: Batch, need_actions: bool = False) -> None:
        """Raise ``ValueError`` naming the key when ``batch`` does not fit this policy."""
        cfg = self.config
        keys = [*IMAGE_KEYS, JOINT_STATES, GRIPPER_STATES, TASK_EMB] + ([ACTIONS] if need_actions else [])
        missing = [k for k in keys if k not in batch]
        if missing:
            raise ValueError(f"batch is missing key(s) {', '.join(missing)}")
        image = batch[AGENTVIEW]
        if image.dim() != 5 or tuple(image.shape[2:]) != (3, cfg.image_size, cfg.image_size):
            raise ValueError(
                f"batch[{AGENTVIEW!r}] must be (B, T, 3, {cfg.image_size}, {cfg.image_size}), "
                f"got {tuple(image.shape)}"
            )
        b, t = image.shape[:2]
        expected = {
            WRIST: (b, t, 3, cfg.image_size, cfg.image_size),
            JOINT_STATES: (b, t, JOINT_DIM),
            GRIPPER_STATES: (b, t, GRIPPER_DIM),
            TASK_EMB: (b, cfg.task_emb_dim),
        }
        if need_actions:
            expected[ACTIONS] = (b, t, cfg.action_dim)
        for key, shape in expected.items():
            if tuple(batch[key].shape) != shape:
                raise ValueError(f"batch[{key!r}] must have shape {shape}, got {tuple(batch[key].shape)}")

    def _augmented(self, batch: Batch) -> Batch:
        cfg = self.config
        if not (self.training and cfg.augment):
            return batch
        agent, wrist = augment_images([batch[AGENTVIEW], batch[WRIST]], cfg.translation, cfg.color_jitter)
        return {**batch, AGENTVIEW: agent, WRIST: wrist}

    def forward(self, batch: Batch) -> MixtureSameFamily:
        self.check_batch(batch)
        return self.head(self.temporal(self.encode_frames(self._augmented(batch))))

    def loss(self, batch: Batch) -> Tensor:
        """Mean negative log-likelihood of the batch's actions over all B * T steps."""
        self.check_batch(batch, need_actions=True)
        dist = self.forward(batch)
        return -dist.log_prob(batch[ACTIONS]).mean()

    @torch.no_grad()
    def act(self, batch: Batch) -> Tensor:
        """Deterministic action (B, A) for the last frame of the window; no state kept."""
        with eval_mode(self):
            self.check_batch(batch)
            features = self.temporal(self.encode_frames(batch))[:, -1]
            return gmm_mode_mean(self.head(features))

    @torch.no_grad()
    def act_step(self, batch: Batch) -> Tensor:
        """Deterministic action (B, A) for one new frame (T = 1), with history since ``reset``."""
        with eval_mode(self):
            self.check_batch(batch)
            if batch[AGENTVIEW].shape[1] != 1:
                raise ValueError(f"act_step takes one frame (T = 1), got T = {batch[AGENTVIEW].shape[1]}")
            return gmm_mode_mean(self.head(self.temporal_step(self.encode_frames(batch))))

    def temporal_rows(self, frames: Tensor, history: list[Any]) -> tuple[Tensor, list[Any]]:
        """Features (B, D) of one new frame per row (B, 1, ...), each row with its own history
        (``None``: a new episode); returns the rows' histories with the new frame."""
        raise NotImplementedError

    @torch.no_grad()
    def act_rows(self, batch: Batch, history: list[Any]) -> tuple[Tensor, list[Any]]:
        """Actions (B, A) for one new frame per row, row ``i`` continuing ``history[i]`` (``None``:
        a new episode), in one pass; returns the new histories. Row ``i`` is what ``act_step``
        gives that row's episode alone, so environments can start and end at different steps
        while they share the batch (up to the last bits a batched matrix product may change)."""
        with eval_mode(self):
            self.check_batch(batch)
            if batch[AGENTVIEW].shape[1] != 1 or len(history) != batch[AGENTVIEW].shape[0]:
                raise ValueError("act_rows takes one frame (T = 1) and one history per row")
            features, history = self.temporal_rows(self.encode_frames(batch), history)
            return gmm_mode_mean(self.head(features)), history


class TokenPolicy(Policy):
    """Shared temporal part of ResNet-T and ViT-T: frames are token sets (B, T, K, D) and a
    block-causal temporal transformer reads them; ``act_step`` keeps the last ``window``
    frames' tokens."""

    temporal_transformer: nn.Module

    def __init__(self, config: PolicyConfig) -> None:
        super().__init__(config)
        self._queue: list[Tensor] = []

    def temporal(self, frames: Tensor) -> Tensor:
        return self.temporal_transformer(frames)

    def temporal_step(self, frames: Tensor) -> Tensor:
        if self._queue and self._queue[0].shape[0] != frames.shape[0]:
            raise ValueError("batch size changed since the last act_step; call reset() first")
        self._queue.append(frames)
        self._queue = self._queue[-self.config.window :]
        return self.temporal_transformer(torch.cat(self._queue, dim=1))[:, -1]

    def reset(self) -> None:
        self._queue = []

    def temporal_rows(self, frames: Tensor, history: list[Any]) -> tuple[Tensor, list[Any]]:
        # A row's history is its last ``window`` frames' tokens; rows of equal history length
        # share one pass of the temporal transformer (all of them, once every episode is
        # ``window`` steps old).
        window = self.config.window
        kept = [[*(h or []), frames[i : i + 1]][-window:] for i, h in enumerate(history)]
        rows_by_length: dict[int, list[int]] = {}
        for i, h in enumerate(kept):
            rows_by_length.setdefault(len(h), []).append(i)
        parts: dict[int, Tensor] = {}
        for rows in rows_by_length.values():
            x = torch.cat([torch.cat(kept[i], dim=1) for i in rows], dim=0)
            y = self.temporal_transformer(x)[:, -1]
            parts.update({i: y[j] for j, i in enumerate(rows)})
        out = torch.stack([parts[i] for i in range(len(kept))])
        return out, kept
