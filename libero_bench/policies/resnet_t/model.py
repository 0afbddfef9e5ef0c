"""ResNet-T: per frame, a language token, joint and gripper tokens and one FiLM-ResNet token
per camera; a block-causal temporal transformer over the window; a GMM head on the language
token's output."""

from __future__ import annotations

import torch
from torch import Tensor, nn

from libero_bench.data.batch_keys import AGENTVIEW, GRIPPER_STATES, JOINT_STATES, TASK_EMB, WRIST
from libero_bench.policies.base import Batch, TokenPolicy
from libero_bench.policies.modules.film_resnet import FiLMResNetEncoder
from libero_bench.policies.modules.gmm import GMMHead
from libero_bench.policies.modules.lowdim import LowDimTokens, mlp
from libero_bench.policies.modules.transformer import TemporalTransformer
from libero_bench.policies.resnet_t.config import ResNetTConfig


class ResNetT(TokenPolicy):
    """Tokens per frame: [language, joint, gripper, agentview, wrist]."""

    config_class = ResNetTConfig
    config: ResNetTConfig

    def __init__(self, config: ResNetTConfig) -> None:
        super().__init__(config)
        c = config
        self.image_encoders = nn.ModuleDict(
            {
                key: FiLMResNetEncoder(c.image_size, c.embed_dim, c.task_emb_dim, c.resnet_channels, c.film)
                for key in (AGENTVIEW, WRIST)
            }
        )
        self.language = mlp(c.task_emb_dim, c.embed_dim, c.embed_dim, 1)
        self.lowdim = LowDimTokens(c.embed_dim)
        self.temporal_transformer = TemporalTransformer(
            c.embed_dim, c.num_layers, c.num_heads, c.head_dim, c.mlp_dim, c.dropout, c.position_base
        )
        self.head = GMMHead(
            c.embed_dim, c.action_dim, c.head_hidden_dim, c.head_num_layers, c.num_modes, c.min_std
        )

    def _encode_images(self, key: str, images: Tensor, task_emb: Tensor) -> Tensor:
        b, t = images.shape[:2]
        lang = task_emb[:, None].expand(b, t, task_emb.shape[-1]).reshape(b * t, -1)
        return self.image_encoders[key](images.flatten(0, 1), lang).view(b, t, 1, -1)

    def encode_frames(self, batch: Batch) -> Tensor:
        task_emb = batch[TASK_EMB]
        agent = self._encode_images(AGENTVIEW, batch[AGENTVIEW], task_emb)
        wrist = self._encode_images(WRIST, batch[WRIST], task_emb)
        b, t = agent.shape[:2]
        lang = self.language(task_emb)[:, None, None].expand(b, t, 1, -1)
        lowdim = self.lowdim(batch[JOINT_STATES], batch[GRIPPER_STATES])
        return torch.cat([lang, lowdim, agent, wrist], dim=2)

    def visual_latent(self, images: Tensor, task_emb: Tensor) -> Tensor:
        return self.image_encoders[AGENTVIEW](images, task_emb)
