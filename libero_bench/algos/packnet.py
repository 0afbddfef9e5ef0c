"""PackNet (Mallya & Lazebnik 2018): every task owns a slice of the weights.

Each weight matrix / kernel of the linear, convolution and LSTM layers carries an integer
mask: 0 = free, k + 1 = owned by task k. Training task k updates only the weights that were free when it started (all of them for the first task);
``end_task`` then prunes ``prune_fraction`` (75 %) of them by magnitude, so task k keeps the
25 % largest, and the pruned ones return to the pool (zeroed). The trainer then fine-tunes
the kept weights for ``post_task_epochs`` (the paper's post-prune fine-tuning); metrics of
the learning curve are taken before it, and it may evaluate right after ``end_task``.

Everything else (biases, normalisation parameters and batch-norm statistics, learned tokens
and position embeddings) trains with the first task only and is frozen afterwards.

Freezing is enforced exactly: ``after_step`` (and every ``loss``) writes the frozen values
back, so an optimiser with momentum or weight decay cannot move them; frozen weights stay
bit-identical. ``set_eval_task(j)`` evaluates with task j's view of the network (weights of
tasks <= j, the rest zero) and ``set_eval_task(None)`` restores the training weights.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from libero_bench.algos.base import ALGO_CONFIGS, Algo, AlgoConfig, Batch, DataloaderFactory

if TYPE_CHECKING:
    from torch import Tensor, nn

    from libero_bench.policies.base import Policy


logger = logging.getLogger(__name__)


def _norms() -> tuple[type, ...]:
    """The normalisation layers (their weights and statistics are never pruned)."""
    from torch import nn

    return (
        nn.modules.batchnorm._BatchNorm,
        nn.LayerNorm,
        nn.GroupNorm,
        nn.modules.instancenorm._InstanceNorm,
    )


@ALGO_CONFIGS.register("packnet")
@dataclass(frozen=True)
class PackNetConfig(AlgoConfig):
    name: ClassVar[str] = "packnet"
    algorithm: ClassVar[str] = "libero_bench.algos.packnet:PackNet"
    sizes: ClassVar[dict[str, dict[str, Any]]] = {"smoke": {"post_prune_epochs": 1}}

    prune_fraction: float = 0.75
    post_prune_epochs: int = 50

    def __post_init__(self) -> None:
        if not 0.0 <= self.prune_fraction < 1.0:
            self._fail("prune_fraction", "must be in [0, 1)")
        if self.post_prune_epochs < 0:
            self._fail("post_prune_epochs", "must be >= 0")


def prunable_names(policy: nn.Module) -> list[str]:
    """Weights that PackNet splits between tasks: the ``weight*`` tensors with two or more
    dimensions of layers that are not normalisation layers (linear, convolution, LSTM)."""
    names = []
    for module_name, module in policy.named_modules():
        if isinstance(module, _norms()):
            continue
        for p_name, p in module.named_parameters(recurse=False):
            if p_name.startswith("weight") and p.dim() >= 2:
                names.append(f"{module_name}.{p_name}" if module_name else p_name)
    return names


class PackNet(Algo):
    config_class = PackNetConfig
    config: PackNetConfig

    def __init__(self, config: PackNetConfig | None = None) -> None:
        super().__init__(config)
        self.masks: dict[str, Tensor] = {}
        self._trainable: dict[str, Tensor | None] = {}  # None: fully trainable
        self._frozen: dict[str, Tensor] = {}
        self._eval_backup: dict[str, Tensor] | None = None

    @property
    def post_task_epochs(self) -> int:
        return self.config.post_prune_epochs

    def _params(self) -> dict[str, nn.Parameter]:
        return dict(self.policy.named_parameters())

    def _buffers_to_freeze(self) -> dict[str, Tensor]:
        return {
            n: b
            for n, b in self.policy.named_buffers()
            if any(n.startswith(m) for m in self._norm_prefixes())
        }

    def _norm_prefixes(self) -> list[str]:
        return [f"{n}." for n, m in self.policy.named_modules() if isinstance(m, _norms())]

    def _norm_modules(self) -> list[nn.Module]:
        return [m for m in self.policy.modules() if isinstance(m, _norms())]

    def _snapshot(self) -> None:
        """Record which entries may change in the current phase and the values of the rest."""
        import torch

        self._frozen, self._trainable = {}, {}
        shared_frozen = self.task_index > 0
        for name, p in self._params().items():
            if name in self.masks:
                trainable = self.masks[name] == self.task_index + 1
                self._trainable[name] = trainable
                self._frozen[name] = p.detach().clone()
            elif shared_frozen:
                self._trainable[name] = torch.zeros_like(p, dtype=torch.bool)
                self._frozen[name] = p.detach().clone()
            else:
                self._trainable[name] = None
        if shared_frozen:
            for name, b in self._buffers_to_freeze().items():
                self._frozen[f"buffer:{name}"] = b.detach().clone()

    def _restore_frozen(self) -> None:
        import torch

        if not self._frozen:
            return
        with torch.no_grad():
            params = self._params()
            for name, trainable in self._trainable.items():
                if trainable is None:
                    continue
                p = params[name]
                p.copy_(torch.where(trainable, p, self._frozen[name]))
            for name, b in self._buffers_to_freeze().items():
                saved = self._frozen.get(f"buffer:{name}")
                if saved is not None:
                    b.copy_(saved)

    # -- task boundaries ----------------------------------------------------------------------
    def start_task(self, task_index: int, policy: Policy) -> None:
        import torch

        if self._policy is not None:
            self.set_eval_task(None)
        super().start_task(task_index, policy)
        if not self.masks:
            params = self._params()
            self.masks = {n: torch.zeros_like(params[n], dtype=torch.int16) for n in prunable_names(policy)}
        for mask in self.masks.values():
            mask[mask == 0] = task_index + 1
        self._snapshot()

    def loss(self, batch: Batch) -> dict[str, Tensor]:
        self.set_eval_task(None)
        self._restore_frozen()
        if self.task_index > 0:
            for module in self._norm_modules():
                module.eval()  # frozen statistics, as at the end of the first task
        return super().loss(batch)

    def after_step(self) -> None:
        self._restore_frozen()

    def end_task(self, task_index: int, dataloader_factory: DataloaderFactory) -> None:
        import torch

        super().end_task(task_index, dataloader_factory)
        self.set_eval_task(None)
        self._restore_frozen()
        owner = task_index + 1
        pruned = total = 0
        with torch.no_grad():
            params = self._params()
            for name, mask in self.masks.items():
                owned = (mask == owner).flatten()
                count = int(owned.sum())
                n_prune = round(self.config.prune_fraction * count)
                total += count
                if n_prune == 0:
                    continue
                weights = params[name].detach().flatten()
                candidates = owned.nonzero().squeeze(1)
                order = weights[candidates].abs().argsort(stable=True)
                drop = candidates[order[:n_prune]]
                mask.view(-1)[drop] = 0
                params[name].view(-1)[drop] = 0.0
                pruned += n_prune
        logger.info("PackNet: task %d keeps %d of %d weights", task_index, total - pruned, total)
        # fine-tuning phase: only the kept weights of this task move; pruned ones stay zero
        self._snapshot()

    # -- evaluation ---------------------------------------------------------------------------
    def set_eval_task(self, task_index: int | None) -> None:
        import torch

        if task_index is None:
            if self._eval_backup is not None:
                with torch.no_grad():
                    params = self._params()
                    for name, value in self._eval_backup.items():
                        params[name].copy_(value)
                self._eval_backup = None
            return
        if task_index < 0:
            raise ValueError(f"task_index must be >= 0, got {task_index}")
        self.set_eval_task(None)
        params = self._params()
        self._eval_backup = {n: params[n].detach().clone() for n in self.masks}
        with torch.no_grad():
            for name, mask in self.masks.items():
                visible = (mask > 0) & (mask <= task_index + 1)
                params[name].copy_(torch.where(visible, params[name], torch.zeros_like(params[name])))

    # -- checkpoints --------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        return {**super().state_dict(), "masks": {n: m.cpu().clone() for n, m in self.masks.items()}}

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        super().load_state_dict(state)
        self.masks = {n: m.clone() for n, m in state["masks"].items()}
        self._frozen, self._trainable, self._eval_backup = {}, {}, None

    def bind(self, policy: Policy) -> None:
        super().bind(policy)
        device = next(policy.parameters()).device
        self.masks = {n: m.to(device) for n, m in self.masks.items()}
        if self.masks and self.task_index >= 0 and not self._frozen:
            # a loaded state (a task resumed after an epoch): what may not move is what the saved
            # weights hold, as the masks and the task in progress say
            self._snapshot()
