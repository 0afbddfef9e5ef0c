"""LIBERO policies (ResNet-RNN, ResNet-T, ViT-T): one folder each, ``config.py`` (registered,
torch-free) and ``model.py`` (the torch module, imported when a policy is built).

Importing this package does not import torch: a policy's config is found through
``POLICY_CONFIGS`` (every ``<policy>/config.py`` of this package registers its own), and
:func:`build_policy` imports the model the config names. The policy interface is
:mod:`libero_bench.policies.base`.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from typing import TYPE_CHECKING, Any

from libero_bench.policies.config_base import POLICY_CONFIGS, PolicyConfig

if TYPE_CHECKING:
    from libero_bench.policies.base import Policy

#: folders here that hold no policy
SHARED = ("modules",)


@functools.cache
def _registered() -> tuple[str, ...]:
    for module in pkgutil.iter_modules(__path__):
        if module.ispkg and module.name not in SHARED:
            importlib.import_module(f"{__name__}.{module.name}.config")
    return tuple(POLICY_CONFIGS.names())


def policy_names() -> list[str]:
    """Every registered policy."""
    return list(_registered())


def policy_config_class(name: str) -> type[PolicyConfig]:
    """The config class of the policy ``name`` (an UnknownNameError naming the known ones otherwise)."""
    _registered()
    return POLICY_CONFIGS.get(name)


def policy_config(name: str, size: str = "paper", **overrides: Any) -> PolicyConfig:
    """The config of the registered policy ``name`` at ``size`` (``libero_bench.sizes``)."""
    return policy_config_class(name).size(size, **overrides)


def config_from_dict(data: dict[str, Any]) -> PolicyConfig:
    """Rebuild a policy config saved with ``to_dict`` (its ``type`` picks the policy)."""
    if "type" not in data:
        raise ValueError("policy config dict has no 'type' field")
    return policy_config_class(str(data["type"])).from_dict(data)


def build_policy(config: PolicyConfig) -> Policy:
    """The torch policy of ``config`` (imports its model)."""
    module, _, name = type(config).model.partition(":")
    cls = getattr(importlib.import_module(module), name)
    policy: Policy = cls.from_config(config)
    return policy


def make_policy(name: str, size: str = "paper", **overrides: Any) -> Policy:
    """Build the registered policy ``name`` at ``size`` with config overrides."""
    return build_policy(policy_config(name, size, **overrides))


__all__ = [
    "POLICY_CONFIGS",
    "PolicyConfig",
    "build_policy",
    "config_from_dict",
    "make_policy",
    "policy_config",
    "policy_config_class",
    "policy_names",
]
