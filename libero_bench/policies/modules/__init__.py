"""Building blocks shared by the policies: GMM head, FiLM ResNet, patch encoder, transformer."""

from libero_bench.policies.modules.augment import augment_images
from libero_bench.policies.modules.film_resnet import FiLMResNetEncoder, SpatialSoftmax
from libero_bench.policies.modules.gmm import GMMHead, gmm_mode_mean
from libero_bench.policies.modules.lowdim import LowDimTokens, mlp
from libero_bench.policies.modules.patch_encoder import PatchEncoder
from libero_bench.policies.modules.positional import SinusoidalPositionEncoding
from libero_bench.policies.modules.transformer import (
    TemporalTransformer,
    Transformer,
    block_causal_mask,
)

__all__ = [
    "FiLMResNetEncoder",
    "GMMHead",
    "LowDimTokens",
    "PatchEncoder",
    "SinusoidalPositionEncoding",
    "SpatialSoftmax",
    "TemporalTransformer",
    "Transformer",
    "augment_images",
    "block_causal_mask",
    "gmm_mode_mean",
    "mlp",
]
