"""Config of ResNet-T: FiLM ResNet per camera, temporal transformer over tokens, GMM head."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from libero_bench.policies.config_base import POLICY_CONFIGS, PolicyConfig


@POLICY_CONFIGS.register("resnet_t")
@dataclass(frozen=True)
class ResNetTConfig(PolicyConfig):
    """Paper Table III / upstream ``bc_transformer_policy.yaml``: token size 64, a temporal
    transformer of 4 layers with 6 heads of 64 dims and an MLP of 256, dropout 0.1,
    sinusoidal temporal positions, language as the first token of every timestep."""

    name: ClassVar[str] = "resnet_t"
    model: ClassVar[str] = "libero_bench.policies.resnet_t.model:ResNetT"
    sizes: ClassVar[dict[str, dict[str, Any]]] = {
        "quick": {
            "embed_dim": 64,
            "resnet_channels": (16, 32),
            "num_layers": 2,
            "num_heads": 4,
            "head_dim": 16,
            "mlp_dim": 128,
            "head_hidden_dim": 256,
            "head_num_layers": 2,
            "augment": False,
        },
        "smoke": {
            "embed_dim": 16,
            "resnet_channels": (8, 16),
            "num_layers": 1,
            "num_heads": 2,
            "head_dim": 8,
            "mlp_dim": 32,
            "head_hidden_dim": 32,
            "head_num_layers": 1,
            "augment": False,
        },
    }

    embed_dim: int = 64
    resnet_channels: tuple[int, int] = (64, 128)
    film: bool = True
    num_layers: int = 4
    num_heads: int = 6
    head_dim: int = 64
    mlp_dim: int = 256
    dropout: float = 0.1
    position_base: float = 10.0

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_positive("embed_dim", "num_layers", "num_heads", "head_dim", "mlp_dim")
        self._check_probability("dropout")
        if len(self.resnet_channels) != 2 or any(
            not isinstance(c, int) or isinstance(c, bool) or c <= 0 for c in self.resnet_channels
        ):
            self._fail("resnet_channels", "must be two positive integers")
        if self.image_size < 8:
            self._fail("image_size", "must be at least 8 for the ResNet encoder")
        if not self.position_base > 1.0:
            self._fail("position_base", "must be > 1")
