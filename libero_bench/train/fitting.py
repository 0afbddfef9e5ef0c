"""Fitting a policy to a task's demonstrations: the loader, the optimiser and one epoch."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from libero_data.errors import DatasetError

if TYPE_CHECKING:
    import torch

    from libero_bench.algos import Algo
    from libero_bench.data.windows import TaskLoader
    from libero_bench.policies.base import Policy
    from libero_bench.train.plan import RunPlan
    from libero_bench.train.presets import TrainPreset


def task_loader(
    plan: RunPlan, task_positions: Sequence[int], *, seed: int, device: torch.device, workers: int = 0
) -> TaskLoader:
    """Shuffled training windows of the given tasks' demonstrations (the preset's share of them),
    and of their mixed episodes where the run mixes data (:mod:`libero_bench.data.mixing`)."""
    from libero_bench.data.windows import TaskLoader, WindowDataset

    preset = plan.preset
    demos = preset.demos_per_task
    episodes: list[int] = []
    ids: list[int] = []
    for pos in task_positions:
        chosen = plan.tasks[pos].episodes[:demos] if demos else plan.tasks[pos].episodes
        episodes.extend(chosen)
        ids.extend([pos] * len(chosen))
    dataset = WindowDataset(plan.source, episodes, ids, plan.task_embs, preset.window, preset.image_size)
    if len(dataset) == 0:
        names = ", ".join(plan.tasks[p].name for p in task_positions)
        raise DatasetError(
            f"no training windows for {names}: every episode is shorter than {preset.window} frames"
        )
    if plan.mix is not None and plan.mix.of(task_positions):
        from libero_bench.data.mixing import mixed_windows

        mixed = mixed_windows(
            dataset, plan.mix, task_positions, plan.task_embs, preset.window, preset.image_size
        )
        return TaskLoader(mixed, preset.batch_size, device, seed=seed, shuffle=True, workers=workers)
    return TaskLoader(dataset, preset.batch_size, device, seed=seed, shuffle=True, workers=workers)


def make_optimiser(policy: Policy, preset: TrainPreset, epochs: int) -> tuple[Any, Any]:
    """AdamW and (for ``scheduler="cosine"``) a cosine schedule from ``lr`` to ``lr_min`` over ``epochs``."""
    import torch

    optimiser = torch.optim.AdamW(
        policy.parameters(), lr=preset.lr, betas=preset.betas, weight_decay=preset.weight_decay
    )
    scheduler = None
    if preset.scheduler == "cosine":
        scheduler = torch.optim.lr_scheduler.CosineAnnealingLR(
            optimiser, T_max=max(epochs, 1), eta_min=preset.lr_min
        )
    return optimiser, scheduler


def train_epoch(
    algo: Algo,
    policy: Policy,
    loader: TaskLoader,
    optimiser: Any,
    grad_clip: float,
    label: str,
    on_step: Callable[[float], None],
) -> dict[str, float]:
    """One pass over ``loader``: the algorithm's loss terms, summed, clipped, stepped; returns
    the mean of every term and of the total."""
    import torch

    policy.train()
    sums: dict[str, float] = {}
    batches = 0
    for batch in loader:
        terms = algo.loss(batch)
        total = torch.stack([t for t in terms.values()]).sum()
        optimiser.zero_grad(set_to_none=True)
        total.backward()
        torch.nn.utils.clip_grad_norm_(policy.parameters(), grad_clip)
        optimiser.step()
        algo.after_step()
        for name, value in terms.items():
            sums[name] = sums.get(name, 0.0) + float(value.detach())
        loss = float(total.detach())
        if not math.isfinite(loss):
            raise FloatingPointError(f"{label}: the training loss is {loss}")
        sums["total"] = sums.get("total", 0.0) + loss
        batches += 1
        on_step(loss)
    return {k: v / batches for k, v in sums.items()}


def loss_epoch(policy: Policy, loader: TaskLoader, on_step: Callable[[float], None]) -> dict[str, float]:
    """Epoch 0: the behaviour-cloning loss of the untouched policy (no updates)."""
    import torch

    from libero_bench.policies.base import eval_mode

    total = 0.0
    batches = 0
    with torch.no_grad(), eval_mode(policy):
        for batch in loader:
            loss = float(policy.loss(batch))
            total += loss
            batches += 1
            on_step(loss)
    mean = total / batches
    return {"bc": mean, "total": mean}
