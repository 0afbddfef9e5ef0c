"""Progress callbacks of a benchmark run (the command line draws its bars from them)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from libero_bench.rollouts.jobs import RolloutResult


class RunObserver:
    """Progress callbacks (the CLI draws bars from them); every method is optional."""

    def phase(self, text: str) -> None:
        """A new stage of the run starts (a task, a post-task fine-tuning ...)."""

    def train_start(self, label: str, batches: int) -> None:
        """An epoch of ``batches`` batches starts."""

    def train_step(self, loss: float) -> None:
        """One optimiser step (or loss batch at epoch 0) is done."""

    def eval_start(self, label: str, rollouts: int) -> None:
        """An evaluation round of ``rollouts`` rollouts starts."""

    def rollout_done(self, result: RolloutResult) -> None:
        """One rollout finished."""

    def eval_end(self, label: str, success: float) -> None:
        """An evaluation round finished with this success rate."""
