"""Config of ViT-T: patch tokens + language token through a spatial transformer, then a
temporal transformer, GMM head."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from libero_bench.policies.config_base import POLICY_CONFIGS, PolicyConfig


@POLICY_CONFIGS.register("vit_t")
@dataclass(frozen=True)
class ViTTConfig(PolicyConfig):
    """Paper Table IV / upstream ``bc_vilt_policy.yaml``: 8x8 patches after a stride-2 stem,
    token size 128, a spatial transformer of 7 layers with 8 heads of 120 dims and an MLP of
    256, its summary token projected to 64 for a temporal transformer of 4 layers, 6 heads of
    64 dims, MLP 256; dropout 0.1 in both."""

    name: ClassVar[str] = "vit_t"
    model: ClassVar[str] = "libero_bench.policies.vit_t.model:ViTT"
    sizes: ClassVar[dict[str, dict[str, Any]]] = {
        "quick": {
            "patch_stem_channels": 16,
            "embed_dim": 32,
            "spatial_num_layers": 2,
            "spatial_num_heads": 4,
            "spatial_head_dim": 8,
            "spatial_mlp_dim": 64,
            "temporal_dim": 64,
            "num_layers": 2,
            "num_heads": 4,
            "head_dim": 16,
            "mlp_dim": 128,
            "head_hidden_dim": 256,
            "head_num_layers": 2,
            "augment": False,
        },
        "smoke": {
            "patch_stem_channels": 8,
            "embed_dim": 16,
            "spatial_num_layers": 1,
            "spatial_num_heads": 2,
            "spatial_head_dim": 8,
            "spatial_mlp_dim": 32,
            "temporal_dim": 16,
            "num_layers": 1,
            "num_heads": 2,
            "head_dim": 8,
            "mlp_dim": 32,
            "head_hidden_dim": 32,
            "head_num_layers": 1,
            "augment": False,
        },
    }

    patch_size: int = 8
    patch_stem_channels: int = 64
    embed_dim: int = 128
    spatial_num_layers: int = 7
    spatial_num_heads: int = 8
    spatial_head_dim: int = 120
    spatial_mlp_dim: int = 256
    spatial_dropout: float = 0.1
    temporal_dim: int = 64
    num_layers: int = 4
    num_heads: int = 6
    head_dim: int = 64
    mlp_dim: int = 256
    dropout: float = 0.1
    position_base: float = 10.0

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_positive("patch_size", "patch_stem_channels", "embed_dim", "temporal_dim")
        self._check_positive("spatial_num_layers", "spatial_num_heads", "spatial_head_dim", "spatial_mlp_dim")
        self._check_positive("num_layers", "num_heads", "head_dim", "mlp_dim")
        self._check_probability("spatial_dropout", "dropout")
        if self.image_size % (2 * self.patch_size) != 0:
            self._fail("image_size", f"must be a multiple of 2 * patch_size = {2 * self.patch_size}")
        if not self.position_base > 1.0:
            self._fail("position_base", "must be > 1")
