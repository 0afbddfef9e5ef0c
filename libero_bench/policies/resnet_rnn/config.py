"""Config of ResNet-RNN: FiLM ResNet per camera, LSTM over the window, GMM head."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from libero_bench.policies.config_base import POLICY_CONFIGS, PolicyConfig


@POLICY_CONFIGS.register("resnet_rnn")
@dataclass(frozen=True)
class ResNetRNNConfig(PolicyConfig):
    """Paper Table II / upstream ``bc_rnn_policy.yaml``: image embedding 64 per camera,
    language embedding 32, raw joint + gripper states, a 2-layer LSTM of 1024 units and a
    GMM head (2 x 1024, 5 modes)."""

    name: ClassVar[str] = "resnet_rnn"
    model: ClassVar[str] = "libero_bench.policies.resnet_rnn.model:ResNetRNN"
    sizes: ClassVar[dict[str, dict[str, Any]]] = {
        "quick": {
            "image_embed_dim": 64,
            "text_embed_dim": 32,
            "resnet_channels": (16, 32),
            "rnn_hidden_dim": 128,
            "rnn_num_layers": 2,
            "head_hidden_dim": 256,
            "head_num_layers": 2,
            "augment": False,
        },
        "smoke": {
            "image_embed_dim": 16,
            "text_embed_dim": 8,
            "resnet_channels": (8, 16),
            "rnn_hidden_dim": 32,
            "rnn_num_layers": 1,
            "head_hidden_dim": 32,
            "head_num_layers": 1,
            "augment": False,
        },
    }

    image_embed_dim: int = 64
    text_embed_dim: int = 32
    resnet_channels: tuple[int, int] = (64, 128)
    film: bool = True
    rnn_hidden_dim: int = 1024
    rnn_num_layers: int = 2
    rnn_dropout: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_positive("image_embed_dim", "text_embed_dim", "rnn_hidden_dim", "rnn_num_layers")
        self._check_probability("rnn_dropout")
        if len(self.resnet_channels) != 2 or any(
            not isinstance(c, int) or isinstance(c, bool) or c <= 0 for c in self.resnet_channels
        ):
            self._fail("resnet_channels", "must be two positive integers")
        if self.image_size < 8:
            self._fail("image_size", "must be at least 8 for the ResNet encoder")
