"""ViT-T: per frame, patch tokens of both cameras and a language token go through a spatial
transformer whose summary token, with language, joint and gripper tokens, feeds a
block-causal temporal transformer; a GMM head reads the language token's output."""

from __future__ import annotations

import torch
from torch import Tensor, nn

from libero_bench.data.batch_keys import AGENTVIEW, GRIPPER_STATES, JOINT_STATES, TASK_EMB, WRIST
from libero_bench.policies.base import Batch, TokenPolicy
from libero_bench.policies.modules.gmm import GMMHead
from libero_bench.policies.modules.lowdim import LowDimTokens, mlp
from libero_bench.policies.modules.patch_encoder import PatchEncoder
from libero_bench.policies.modules.transformer import TemporalTransformer, Transformer
from libero_bench.policies.vit_t.config import ViTTConfig


class ViTT(TokenPolicy):
    """Spatial tokens: [summary, agentview patches, wrist patches, language]; temporal tokens
    per frame: [language, spatial summary, joint, gripper]."""

    config_class = ViTTConfig
    config: ViTTConfig
    modality_index: Tensor

    def __init__(self, config: ViTTConfig) -> None:
        super().__init__(config)
        c = config
        self.patch_encoders = nn.ModuleDict(
            {
                key: PatchEncoder(c.image_size, c.patch_size, c.embed_dim, c.patch_stem_channels)
                for key in (AGENTVIEW, WRIST)
            }
        )
        num_patches = (c.image_size // 2 // c.patch_size) ** 2
        self.patch_positions = nn.Parameter(torch.randn(1, 2 * num_patches, c.embed_dim) * 0.02)
        # one learned embedding per modality: agentview patches, wrist patches, language
        self.modality_embeddings = nn.Parameter(torch.randn(3, c.embed_dim) * 0.02)
        self.register_buffer(
            "modality_index",
            torch.tensor([0] * num_patches + [1] * num_patches + [2], dtype=torch.long),
            persistent=False,
        )
        self.summary_token = nn.Parameter(torch.randn(1, 1, c.embed_dim) * 0.02)
        self.spatial_language = mlp(c.task_emb_dim, c.embed_dim, c.embed_dim, 1)
        self.spatial_transformer = Transformer(
            c.embed_dim,
            c.spatial_num_layers,
            c.spatial_num_heads,
            c.spatial_head_dim,
            c.spatial_mlp_dim,
            c.spatial_dropout,
        )
        self.down_sample = nn.Linear(c.embed_dim, c.temporal_dim)
        self.temporal_language = mlp(c.task_emb_dim, c.temporal_dim, c.temporal_dim, 1)
        self.lowdim = LowDimTokens(c.temporal_dim)
        self.temporal_transformer = TemporalTransformer(
            c.temporal_dim, c.num_layers, c.num_heads, c.head_dim, c.mlp_dim, c.dropout, c.position_base
        )
        self.head = GMMHead(
            c.temporal_dim, c.action_dim, c.head_hidden_dim, c.head_num_layers, c.num_modes, c.min_std
        )

    def encode_frames(self, batch: Batch) -> Tensor:
        task_emb = batch[TASK_EMB]
        b, t = batch[AGENTVIEW].shape[:2]
        patches = (
            torch.cat(
                [self.patch_encoders[key](batch[key].flatten(0, 1)) for key in (AGENTVIEW, WRIST)], dim=1
            )
            + self.patch_positions
        )  # (B*T, 2P, E)
        lang = self.spatial_language(task_emb)[:, None, None].expand(b, t, 1, -1).reshape(b * t, 1, -1)
        tokens = torch.cat([patches, lang], dim=1) + self.modality_embeddings[self.modality_index]
        summary = self.summary_token.expand(b * t, 1, -1)
        spatial = self.spatial_transformer(torch.cat([summary, tokens], dim=1))[:, 0]
        spatial = self.down_sample(spatial).view(b, t, 1, -1)
        lang_t = self.temporal_language(task_emb)[:, None, None].expand(b, t, 1, -1)
        lowdim = self.lowdim(batch[JOINT_STATES], batch[GRIPPER_STATES])
        return torch.cat([lang_t, spatial, lowdim], dim=2)

    def visual_latent(self, images: Tensor, task_emb: Tensor) -> Tensor:
        """The agentview patch encoder's tokens, flattened (B, P * E); language does not
        enter this encoder in ViT-T."""
        del task_emb
        return self.patch_encoders[AGENTVIEW](images).flatten(1)
