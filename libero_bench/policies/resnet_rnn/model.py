"""ResNet-RNN: a FiLM ResNet per camera, raw joint + gripper states and a projected task
embedding per frame, an LSTM over the window, and a GMM head."""

from __future__ import annotations

from typing import Any

import torch
from torch import Tensor, nn

from libero_bench.data.batch_keys import (
    AGENTVIEW,
    GRIPPER_DIM,
    GRIPPER_STATES,
    JOINT_DIM,
    JOINT_STATES,
    TASK_EMB,
    WRIST,
)
from libero_bench.policies.base import Batch, Policy
from libero_bench.policies.modules.film_resnet import FiLMResNetEncoder
from libero_bench.policies.modules.gmm import GMMHead
from libero_bench.policies.modules.lowdim import mlp
from libero_bench.policies.resnet_rnn.config import ResNetRNNConfig


class ResNetRNN(Policy):
    """Language enters twice, as in LIBERO: FiLM inside the image encoders (from the raw
    task embedding) and a projected embedding in every frame's LSTM input."""

    config_class = ResNetRNNConfig
    config: ResNetRNNConfig

    def __init__(self, config: ResNetRNNConfig) -> None:
        super().__init__(config)
        c = config
        self.image_encoders = nn.ModuleDict(
            {
                key: FiLMResNetEncoder(
                    c.image_size, c.image_embed_dim, c.task_emb_dim, c.resnet_channels, c.film
                )
                for key in (AGENTVIEW, WRIST)
            }
        )
        self.language = mlp(c.task_emb_dim, c.text_embed_dim, c.text_embed_dim, 1)
        input_dim = 2 * c.image_embed_dim + c.text_embed_dim + JOINT_DIM + GRIPPER_DIM
        self.rnn = nn.LSTM(
            input_dim,
            c.rnn_hidden_dim,
            num_layers=c.rnn_num_layers,
            batch_first=True,
            dropout=c.rnn_dropout if c.rnn_num_layers > 1 else 0.0,
        )
        self.head = GMMHead(
            c.rnn_hidden_dim, c.action_dim, c.head_hidden_dim, c.head_num_layers, c.num_modes, c.min_std
        )
        self._state: tuple[Tensor, Tensor] | None = None

    def _encode_images(self, key: str, images: Tensor, task_emb: Tensor) -> Tensor:
        b, t = images.shape[:2]
        lang = task_emb[:, None].expand(b, t, task_emb.shape[-1]).reshape(b * t, -1)
        return self.image_encoders[key](images.flatten(0, 1), lang).view(b, t, -1)

    def encode_frames(self, batch: Batch) -> Tensor:
        task_emb = batch[TASK_EMB]
        agent = self._encode_images(AGENTVIEW, batch[AGENTVIEW], task_emb)
        wrist = self._encode_images(WRIST, batch[WRIST], task_emb)
        b, t = agent.shape[:2]
        lang = self.language(task_emb)[:, None].expand(b, t, -1)
        return torch.cat([agent, wrist, batch[JOINT_STATES], batch[GRIPPER_STATES], lang], dim=-1)

    def temporal(self, frames: Tensor) -> Tensor:
        output, _ = self.rnn(frames)  # zero initial state: the window is a fresh sequence
        return output

    def temporal_step(self, frames: Tensor) -> Tensor:
        if self._state is not None and self._state[0].shape[1] != frames.shape[0]:
            raise ValueError("batch size changed since the last act_step; call reset() first")
        output, state = self.rnn(frames, self._state)
        self._state = (state[0].detach(), state[1].detach())
        return output[:, -1]

    def reset(self) -> None:
        self._state = None

    def temporal_rows(self, frames: Tensor, history: list[Any]) -> tuple[Tensor, list[Any]]:
        # A row's history is its LSTM state; a new episode's is zero, as in temporal_step.
        layers, hidden = self.rnn.num_layers, self.rnn.hidden_size
        zero = frames.new_zeros((layers, 1, hidden))
        h = torch.cat([zero if s is None else s[0] for s in history], dim=1)
        c = torch.cat([zero if s is None else s[1] for s in history], dim=1)
        output, (h, c) = self.rnn(frames, (h, c))
        return output[:, -1], [(h[:, i : i + 1], c[:, i : i + 1]) for i in range(frames.shape[0])]

    def visual_latent(self, images: Tensor, task_emb: Tensor) -> Tensor:
        return self.image_encoders[AGENTVIEW](images, task_emb)
