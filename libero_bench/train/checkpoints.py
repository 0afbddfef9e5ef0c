"""Writing a run's per-task checkpoints (policy, algorithm state, random streams) and epoch
states, the weights a run may start from, and seeding the process's random streams. Reading a
run's checkpoints is :mod:`libero_bench.runs.saved_policy`'s."""

from __future__ import annotations

import logging
import random
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_bench.runs.folder import RUN_FORMAT, RunResults
from libero_bench.runs.saved_policy import CHECKPOINT, EPOCH_STATE, load_into, read_checkpoint
from libero_bench.runs.state_files import load_state, load_weights, save_state
from libero_data.errors import InputError, first_line

if TYPE_CHECKING:
    import torch

    from libero_bench.algos import Algo
    from libero_bench.policies.base import Policy

logger = logging.getLogger(__name__)


def seed_everything(seed: int) -> None:
    """Seed torch, NumPy's global stream and Python's ``random``."""
    import torch

    torch.manual_seed(seed)
    np.random.seed(seed % 2**32)
    random.seed(seed)


def rng_state() -> dict[str, Any]:
    """The random streams' state (saved with each checkpoint)."""
    import torch

    return {"torch": torch.get_rng_state(), "numpy": np.random.get_state(), "python": random.getstate()}


def save_checkpoint(
    path: Path, *, task: int, stage: str, policy_config: dict[str, Any], policy: Policy, algo: Algo
) -> Path:
    """Write the checkpoint after ``task`` atomically (safetensors: see :mod:`state_files`)."""
    state = {
        "format": RUN_FORMAT,
        "task": task,
        "stage": stage,
        "policy_config": policy_config,
        "policy": {k: v.detach().cpu() for k, v in policy.state_dict().items()},
        "algo": algo.state_dict(),
        "rng": rng_state(),
    }
    return save_state(path, state, kind=CHECKPOINT)


def restore_rng(state: dict[str, Any]) -> None:
    """Put the random streams back where :func:`rng_state` found them."""
    import torch

    torch.set_rng_state(state["torch"])
    np.random.set_state(state["numpy"])
    random.setstate(state["python"])


#: the phases of a task an epoch state belongs to: its epochs, or the post-task epochs (PackNet)
LEARN, POST_TASK = "learn", "post_task"


@dataclass(frozen=True)
class Training:
    """What changes while a task is trained: its epoch states save and restore all of it."""

    policy: Policy
    algo: Algo
    optimiser: Any
    scheduler: Any

    def save(
        self, path: Path, phase: str, positions: list[int], epoch: int, results: RunResults, **extra: Any
    ) -> Path:
        """Write the state after a finished epoch of the task in progress atomically: everything
        :meth:`restore` needs to go on as if the task had not been interrupted."""
        state = {
            "format": RUN_FORMAT,
            "phase": phase,
            "positions": positions,
            "epoch": epoch,
            "policy": self.policy.state_dict(),
            "algo": self.algo.state_dict(),
            "optimiser": self.optimiser.state_dict(),
            "scheduler": self.scheduler.state_dict() if self.scheduler is not None else None,
            "results": results.to_dict(),
            **extra,
            "rng": rng_state(),
        }
        return save_state(path, state, kind=EPOCH_STATE)

    def restore(self, saved: dict[str, Any], results: RunResults) -> None:
        """Weights, algorithm state, optimiser, schedule, results and random streams as they were
        after the saved epoch."""
        self.policy.load_state_dict(saved["policy"])
        self.algo.load_state_dict(saved["algo"])
        self.algo.bind(self.policy)
        self.optimiser.load_state_dict(saved["optimiser"])
        if self.scheduler is not None and saved["scheduler"] is not None:
            self.scheduler.load_state_dict(saved["scheduler"])
        vars(results).update(vars(RunResults.from_dict(saved["results"])))
        restore_rng(saved["rng"])


def load_epoch_state(path: Path, positions: list[int], phase: str = LEARN) -> dict[str, Any] | None:
    """The state :meth:`Training.save` wrote for these task positions in ``phase``, or None
    (a state written before phases were recorded belongs to the task's epochs)."""
    if not path.is_file():
        return None
    data = load_state(path, kind=EPOCH_STATE)
    if not isinstance(data, dict) or data.get("format") != RUN_FORMAT or data.get("positions") != positions:
        return None
    return data if data.get("phase", LEARN) == phase else None


def load_checkpoint(path: Path, policy: Policy, algo: Algo) -> None:
    """Load a checkpoint's policy weights and algorithm state (and bind the two)."""
    load_into(path, policy, algo, read_checkpoint(path))


def load_initial_weights(path: Path, policy: Policy, device: torch.device, policy_name: str) -> None:
    """Start ``policy`` from other weights (a run's checkpoint, or bare safetensors weights)."""
    state = load_weights(path, device=str(device))
    try:
        policy.load_state_dict(state)
    except RuntimeError as exc:
        first = first_line(exc)
        raise InputError(
            f"the initial checkpoint {path} does not fit the {policy_name} policy: {first}",
            field="init_checkpoint",
        ) from None
    logger.info("policy initialised from %s", path)
