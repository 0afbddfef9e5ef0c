"""EWC: online elastic weight consolidation (Schwarz et al. 2018 variant used by LIBERO).

After each task the diagonal empirical Fisher ``F_new`` (squared gradients of the batch-mean
negative log-likelihood, averaged over the task's batches) is folded into a running estimate
``F <- gamma * F + F_new`` (LIBERO's form; gamma = 0.9), and the weights are stored as the
anchor. While learning later tasks the loss gains ``lambda * sum F * (theta - anchor)^2``
(lambda = 5e4).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from libero_bench.algos.base import ALGO_CONFIGS, Algo, AlgoConfig, Batch, DataloaderFactory

if TYPE_CHECKING:
    from torch import Tensor

    from libero_bench.policies.base import Policy


logger = logging.getLogger(__name__)


@ALGO_CONFIGS.register("ewc")
@dataclass(frozen=True)
class EWCConfig(AlgoConfig):
    name: ClassVar[str] = "ewc"
    algorithm: ClassVar[str] = "libero_bench.algos.ewc:EWC"
    sizes: ClassVar[dict[str, dict[str, Any]]] = {"smoke": {"fisher_batches": 4}}

    penalty_weight: float = 5e4
    gamma: float = 0.9
    fisher_batches: int | None = None  # None: one full pass over the task's batches

    def __post_init__(self) -> None:
        if not self.penalty_weight >= 0:
            self._fail("penalty_weight", "must be >= 0")
        if not 0.0 <= self.gamma <= 1.0:
            self._fail("gamma", "must be in [0, 1]")
        if self.fisher_batches is not None and self.fisher_batches <= 0:
            self._fail("fisher_batches", "must be positive or None")


class EWC(Algo):
    config_class = EWCConfig
    config: EWCConfig

    def __init__(self, config: EWCConfig | None = None) -> None:
        super().__init__(config)
        self.fisher: dict[str, Tensor] = {}
        self.anchor: dict[str, Tensor] = {}

    def penalty(self) -> Tensor:
        """``sum F * (theta - anchor)^2`` over all parameters (0 before the first task ends)."""
        import torch

        params = dict(self.policy.named_parameters())
        device = next(iter(params.values())).device
        total = torch.zeros((), device=device)
        for name, fisher in self.fisher.items():
            total = total + (fisher * (params[name] - self.anchor[name]).pow(2)).sum()
        return total

    def loss(self, batch: Batch) -> dict[str, Tensor]:
        terms = super().loss(batch)
        terms["ewc"] = self.config.penalty_weight * self.penalty()
        return terms

    def end_task(self, task_index: int, dataloader_factory: DataloaderFactory) -> None:
        import torch

        super().end_task(task_index, dataloader_factory)
        policy = self.policy
        params = {n: p for n, p in policy.named_parameters() if p.requires_grad}
        saved_grads = {n: p.grad for n, p in params.items()}
        fisher = {n: torch.zeros_like(p) for n, p in params.items()}
        batches = 0
        # eval mode: no dropout or augmentation noise, batch-norm statistics left untouched
        from libero_bench.policies.base import eval_mode

        with eval_mode(policy):
            for batch in dataloader_factory():
                for p in params.values():
                    p.grad = None
                policy.loss(batch).backward()
                for n, p in params.items():
                    if p.grad is not None:
                        fisher[n] += p.grad.detach().pow(2)
                batches += 1
                if self.config.fisher_batches is not None and batches >= self.config.fisher_batches:
                    break
        for n, p in params.items():
            p.grad = saved_grads[n]
        if batches == 0:
            raise ValueError(f"EWC.end_task({task_index}): the dataloader gave no batches")
        for n in fisher:
            fisher[n] /= batches
            previous = self.fisher.get(n)
            self.fisher[n] = fisher[n] if previous is None else self.config.gamma * previous + fisher[n]
            self.anchor[n] = params[n].detach().clone()
        logger.info("EWC: Fisher from %d batches after task %d", batches, task_index)

    def state_dict(self) -> dict[str, Any]:
        return {
            **super().state_dict(),
            "fisher": {n: t.cpu() for n, t in self.fisher.items()},
            "anchor": {n: t.cpu() for n, t in self.anchor.items()},
        }

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        super().load_state_dict(state)
        self.fisher = {n: t.clone() for n, t in state["fisher"].items()}
        self.anchor = {n: t.clone() for n, t in state["anchor"].items()}

    def bind(self, policy: Policy) -> None:
        super().bind(policy)
        device = next(policy.parameters()).device
        self.fisher = {n: t.to(device) for n, t in self.fisher.items()}
        self.anchor = {n: t.to(device) for n, t in self.anchor.items()}
