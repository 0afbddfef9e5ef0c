"""The lifelong-learning algorithm interface and the ``ALGO_CONFIGS`` registry.

An algorithm is a small override of how a policy is trained across tasks; the trainer owns
the optimiser, the data and the evaluation. The protocol the trainer follows:

.. code-block:: python

    algo = build_algo(config)                 # libero_bench.algos
    for k in range(K):                        # algo.needs_all_tasks: once, on all tasks' data
        algo.start_task(k, policy)
        optimiser = AdamW(policy.parameters(), ...)      # fresh per task
        for epoch ...:
            for batch in task k's loader:
                terms = algo.loss(batch)                 # dict of named loss terms
                optimiser.zero_grad(); sum(terms.values()).backward()
                clip_grad_norm_(...); optimiser.step()
                algo.after_step()                        # e.g. PackNet restores frozen weights
            evaluate (algo.set_eval_task(j) before evaluating task j, then set_eval_task(None))
        load the kept (best) checkpoint of task k into the policy
        algo.end_task(k, lambda: task k's loader)        # Fisher, memory, pruning ...
        # here the trainer may evaluate: for PackNet, the pruned, not yet fine-tuned network
        for epoch in range(algo.post_task_epochs):       # PackNet's post-prune fine-tuning
            same step loop as above, fresh optimiser, no learning-curve entries
        save policy.state_dict() and algo.state_dict()   # per-task checkpoint

``state_dict``/``load_state_dict`` carry everything the algorithm learned (Fisher, replay
memory, masks), so a run resumes from a per-task checkpoint: load both, then ``bind(policy)``
(or ``start_task`` the next task).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Self

from libero_bench.sizes import Sized
from libero_data.config import Config
from libero_data.registry import Registry

if TYPE_CHECKING:
    from torch import Tensor

    from libero_bench.policies.base import Policy


logger = logging.getLogger(__name__)

Batch = Mapping[str, "Tensor"]
DataloaderFactory = Callable[[], Iterable[Batch]]
"""Called with no arguments, gives one pass over a task's training batches."""


@dataclass(frozen=True)
class AlgoConfig(Sized, Config):
    """Base of the algorithm configs (on the project's one config base); ``sizes`` lists what
    the ``smoke`` (tiny CPU runs) and ``quick`` sizes change (:mod:`libero_bench.sizes`)."""

    name: ClassVar[str] = ""
    #: where the algorithm is, ``module:Class`` (imported by ``libero_bench.algos.build_algo``)
    algorithm: ClassVar[str] = ""


#: Every algorithm's config, by name: each algorithm's module registers its own (no torch needed).
ALGO_CONFIGS: Registry[type[AlgoConfig]] = Registry("lifelong algorithm")


class Algo:
    """Sequential fine-tuning behaviour; subclasses override the hooks they need."""

    config_class: ClassVar[type[AlgoConfig]] = AlgoConfig
    needs_all_tasks: ClassVar[bool] = False

    def __init__(self, config: AlgoConfig | None = None) -> None:
        config = config if config is not None else self.config_class()
        if not isinstance(config, self.config_class):
            raise TypeError(
                f"{type(self).__name__} needs a {self.config_class.__name__}, got {type(config).__name__}"
            )
        self.config = config
        self.task_index = -1
        self._policy: Policy | None = None
        #: task number -> that task's data as ``end_task`` got it (the trainer sets it; ER rebuilds
        #: a memory loaded without its windows from it)
        self.task_data: Callable[[int], DataloaderFactory] | None = None

    @classmethod
    def from_config(cls, config: AlgoConfig) -> Self:
        return cls(config)

    @property
    def policy(self) -> Policy:
        if self._policy is None:
            raise RuntimeError(f"{type(self).__name__} has no policy yet: call start_task or bind first")
        return self._policy

    @property
    def post_task_epochs(self) -> int:
        """Extra epochs the trainer runs on the finished task after ``end_task`` (0 here)."""
        return 0

    def bind(self, policy: Policy) -> None:
        """Attach the policy without starting a task (e.g. to evaluate a loaded checkpoint)."""
        self._policy = policy

    def start_task(self, task_index: int, policy: Policy) -> None:
        """Called before training on task ``task_index`` (0-based)."""
        if task_index < 0:
            raise ValueError(f"task_index must be >= 0, got {task_index}")
        self.bind(policy)
        self.task_index = task_index

    def loss(self, batch: Batch) -> dict[str, Tensor]:
        """Named loss terms for one training batch; the trainer sums and backpropagates them."""
        return {"bc": self.policy.loss(batch)}

    def after_step(self) -> None:
        """Called after every optimiser step."""

    def end_task(self, task_index: int, dataloader_factory: DataloaderFactory) -> None:
        """Called once task ``task_index`` is learned (with its kept checkpoint loaded)."""
        if task_index != self.task_index:
            raise ValueError(f"end_task({task_index}) does not match start_task({self.task_index})")

    def set_eval_task(self, task_index: int | None) -> None:
        """Prepare the policy to be evaluated on ``task_index``; ``None`` restores training weights."""

    def state_dict(self) -> dict[str, Any]:
        return {"config": self.config.to_dict(), "task_index": self.task_index}

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        saved = state.get("config")
        if saved is not None and saved != self.config.to_dict():
            logger.warning("loading %s state saved with a different config: %s", type(self).__name__, saved)
        self.task_index = int(state["task_index"])
