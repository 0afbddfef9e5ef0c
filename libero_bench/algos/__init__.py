"""Lifelong-learning algorithms (SeqL, ER, EWC, PackNet, MTL): one module each, holding the
algorithm's config (registered in ``ALGO_CONFIGS``) and the algorithm.

Importing this package does not import torch: every module of it registers its config when the
registry is first asked (:func:`algo_names`), and :func:`build_algo` builds the algorithm a
config names. The interface is :mod:`libero_bench.algos.base`.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from typing import Any

from libero_bench.algos.base import ALGO_CONFIGS, Algo, AlgoConfig, DataloaderFactory

#: modules here that hold no algorithm
SHARED = ("base",)


@functools.cache
def _registered() -> tuple[str, ...]:
    for module in pkgutil.iter_modules(__path__):
        if module.name not in SHARED:
            importlib.import_module(f"{__name__}.{module.name}")
    return tuple(ALGO_CONFIGS.names())


def algo_names() -> list[str]:
    """Every registered algorithm."""
    return list(_registered())


def algo_config_class(name: str) -> type[AlgoConfig]:
    """The config class of the algorithm ``name`` (an UnknownNameError naming the known ones otherwise)."""
    _registered()
    return ALGO_CONFIGS.get(name)


def algo_class(name: str) -> type[Algo]:
    """The algorithm ``name`` itself (its class, as its config names it)."""
    module, _, cls = algo_config_class(name).algorithm.partition(":")
    found: type[Algo] = getattr(importlib.import_module(module), cls)
    return found


def algo_config(name: str, size: str = "paper", **overrides: Any) -> AlgoConfig:
    """The config of the algorithm ``name`` at ``size`` (``libero_bench.sizes``)."""
    return algo_config_class(name).size(size, **overrides)


def algo_config_from_dict(data: dict[str, Any]) -> AlgoConfig:
    """Rebuild an algorithm config saved with ``to_dict`` (its ``type`` picks the algorithm)."""
    if "type" not in data:
        raise ValueError("algorithm config dict has no 'type' field")
    return algo_config_class(str(data["type"])).from_dict(data)


def build_algo(config: AlgoConfig) -> Algo:
    """The algorithm of ``config``."""
    return algo_class(config.name)(config)


def make_algo(name: str, size: str = "paper") -> Algo:
    """Build the algorithm ``name`` at ``size``."""
    return build_algo(algo_config(name, size))


__all__ = [
    "ALGO_CONFIGS",
    "Algo",
    "AlgoConfig",
    "DataloaderFactory",
    "algo_class",
    "algo_config",
    "algo_config_class",
    "algo_config_from_dict",
    "algo_names",
    "build_algo",
    "make_algo",
]
