"""Lifelong-learning algorithms (SeqL, ER, EWC, PackNet, MTL), found through ``ALGOS``.

Importing this package imports torch and registers every algorithm.
"""

from __future__ import annotations

from typing import Any

from libero_bench.algos.base import ALGOS, Algo, AlgoConfig, DataloaderFactory
from libero_bench.algos.er import ER, ERConfig
from libero_bench.algos.ewc import EWC, EWCConfig
from libero_bench.algos.mtl import MTL, MTLConfig
from libero_bench.algos.packnet import PackNet, PackNetConfig
from libero_bench.algos.seql import SeqL, SeqLConfig


def make_algo(name: str, size: str = "paper") -> Algo:
    """Build the registered algorithm ``name`` with its ``paper`` or ``smoke`` settings."""
    cls = ALGOS.get(name)
    if size == "paper":
        return cls(cls.config_class())
    if size == "smoke":
        return cls(cls.config_class.smoke())
    raise ValueError(f"unknown algorithm size {size!r}; known: paper, smoke")


def algo_config_from_dict(data: dict[str, Any]) -> AlgoConfig:
    """Rebuild an algorithm config saved with ``to_dict`` (its ``type`` picks the algorithm)."""
    if "type" not in data:
        raise ValueError("algorithm config dict has no 'type' field")
    return ALGOS.get(str(data["type"])).config_class.from_dict(data)


__all__ = [
    "ALGOS",
    "ER",
    "EWC",
    "MTL",
    "Algo",
    "AlgoConfig",
    "DataloaderFactory",
    "ERConfig",
    "EWCConfig",
    "MTLConfig",
    "PackNet",
    "PackNetConfig",
    "SeqL",
    "SeqLConfig",
    "algo_config_from_dict",
    "make_algo",
]
