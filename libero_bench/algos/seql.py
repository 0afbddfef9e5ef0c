"""SeqL: sequential fine-tuning, the plain baseline (one task after another, no protection)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from libero_bench.algos.base import ALGO_CONFIGS, Algo, AlgoConfig


@ALGO_CONFIGS.register("seql")
@dataclass(frozen=True)
class SeqLConfig(AlgoConfig):
    name: ClassVar[str] = "seql"
    algorithm: ClassVar[str] = "libero_bench.algos.seql:SeqL"


class SeqL(Algo):
    """Trains on each new task with the plain behaviour-cloning loss."""

    config_class = SeqLConfig
