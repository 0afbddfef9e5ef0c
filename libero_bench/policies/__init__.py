"""LIBERO policies (ResNet-RNN, ResNet-T, ViT-T), found through the ``POLICIES`` registry.

Importing this package imports torch and registers every policy.
"""

from __future__ import annotations

from typing import Any

from libero_bench.policies.base import POLICIES, Batch, Policy, TokenPolicy, eval_mode
from libero_bench.policies.config_base import PolicyConfig
from libero_bench.policies.resnet_rnn.config import ResNetRNNConfig
from libero_bench.policies.resnet_rnn.model import ResNetRNN
from libero_bench.policies.resnet_t.config import ResNetTConfig
from libero_bench.policies.resnet_t.model import ResNetT
from libero_bench.policies.vit_t.config import ViTTConfig
from libero_bench.policies.vit_t.model import ViTT


def policy_config(name: str, size: str = "paper", **overrides: Any) -> PolicyConfig:
    """The ``paper`` or ``smoke`` config of the registered policy ``name``."""
    return POLICIES.get(name).config_class.size(size, **overrides)


def make_policy(name: str, size: str = "paper", **overrides: Any) -> Policy:
    """Build the registered policy ``name`` at ``size`` with config overrides."""
    return POLICIES.get(name).from_config(policy_config(name, size, **overrides))


def config_from_dict(data: dict[str, Any]) -> PolicyConfig:
    """Rebuild a policy config saved with ``to_dict`` (its ``type`` picks the policy)."""
    if "type" not in data:
        raise ValueError("policy config dict has no 'type' field")
    return POLICIES.get(str(data["type"])).config_class.from_dict(data)


__all__ = [
    "POLICIES",
    "Batch",
    "Policy",
    "PolicyConfig",
    "ResNetRNN",
    "ResNetRNNConfig",
    "ResNetT",
    "ResNetTConfig",
    "TokenPolicy",
    "ViTT",
    "ViTTConfig",
    "config_from_dict",
    "eval_mode",
    "make_policy",
    "policy_config",
]
