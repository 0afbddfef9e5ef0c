"""MTL: multitask learning, the upper-bound baseline trained on all tasks' data at once."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from libero_bench.algos.base import ALGO_CONFIGS, Algo, AlgoConfig


@ALGO_CONFIGS.register("mtl")
@dataclass(frozen=True)
class MTLConfig(AlgoConfig):
    name: ClassVar[str] = "mtl"
    algorithm: ClassVar[str] = "libero_bench.algos.mtl:MTL"


class MTL(Algo):
    """``needs_all_tasks``: the trainer calls ``start_task(0, policy)`` once, trains on the
    union of every task's data (batches mixing tasks) and calls ``end_task(0, ...)``; its
    learning curve is evaluated on all tasks."""

    config_class = MTLConfig
    needs_all_tasks = True
