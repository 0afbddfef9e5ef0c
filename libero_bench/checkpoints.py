"""A run's per-task checkpoints (policy, algorithm state, random streams) and the weights a
run may start from, plus seeding the process's random streams."""

from __future__ import annotations

import io
import logging
import random
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_bench.run_files import RUN_FORMAT, RunFolder
from libero_data.errors import InputError, RunError
from libero_data.runtime.files import write_bytes

if TYPE_CHECKING:
    import torch

    from libero_bench.algos import Algo
    from libero_bench.policies import Policy

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
    """Write the checkpoint after ``task`` atomically."""
    import torch

    buffer = io.BytesIO()
    torch.save(
        {
            "format": RUN_FORMAT,
            "task": task,
            "stage": stage,
            "policy_config": policy_config,
            "policy": {k: v.detach().cpu() for k, v in policy.state_dict().items()},
            "algo": algo.state_dict(),
            "rng": rng_state(),
        },
        buffer,
    )
    return write_bytes(path, buffer.getvalue())


def restore_rng(state: dict[str, Any]) -> None:
    """Put the random streams back where :func:`rng_state` found them."""
    import torch

    torch.set_rng_state(state["torch"])
    np.random.set_state(state["numpy"])
    random.setstate(state["python"])


def save_epoch_state(path: Path, state: dict[str, Any]) -> Path:
    """Write the state after a finished epoch of the task in progress atomically."""
    import torch

    buffer = io.BytesIO()
    torch.save({"format": RUN_FORMAT, **state, "rng": rng_state()}, buffer)
    return write_bytes(path, buffer.getvalue())


def load_epoch_state(path: Path, positions: list[int]) -> dict[str, Any] | None:
    """The state :func:`save_epoch_state` wrote for these task positions, or None."""
    import torch

    if not path.is_file():
        return None
    data = torch.load(path, map_location="cpu", weights_only=False)
    if data.get("format") != RUN_FORMAT or data.get("positions") != positions:
        return None
    return dict(data)


def load_checkpoint(path: Path, policy: Policy, algo: Algo) -> None:
    """Load a checkpoint's policy weights and algorithm state (and bind the two)."""
    import torch

    data = torch.load(path, map_location="cpu", weights_only=False)
    policy.load_state_dict(data["policy"])
    algo.load_state_dict(data["algo"])
    algo.bind(policy)


def load_initial_weights(path: Path, policy: Policy, device: torch.device, policy_name: str) -> None:
    """Start ``policy`` from other weights (a run's checkpoint, or a bare state dict)."""
    import torch

    data = torch.load(path, map_location=device, weights_only=False)
    state = data.get("policy", data) if isinstance(data, dict) else data
    try:
        policy.load_state_dict(state)
    except RuntimeError as exc:
        first = str(exc).strip().splitlines()[0]
        raise InputError(
            f"the initial checkpoint {path} does not fit the {policy_name} policy: {first}",
            field="init_checkpoint",
        ) from None
    logger.info("policy initialised from %s", path)


def kept_checkpoint(folder: RunFolder, config: dict[str, Any], position: int) -> Path:
    """The checkpoint a run kept after the task at ``position`` (MTL: its one checkpoint)."""
    from libero_bench.algos import ALGOS

    index = 0 if ALGOS.get(config["algo"]).needs_all_tasks else position
    path = folder.checkpoint(index)
    if not path.is_file():
        name = config["tasks"][position]["name"]
        raise RunError(f"{folder.root} has no checkpoint after task {name} yet")
    return path


def policy_from_checkpoint(config: dict[str, Any], checkpoint: Path, position: int) -> tuple[Any, Any]:
    """(policy, algorithm) of a checkpoint, in the algorithm's evaluation view of the task."""
    import torch

    from libero_bench.algos import ALGOS, algo_config_from_dict
    from libero_bench.policies import POLICIES, config_from_dict

    pconfig = config_from_dict(config["policy_config"])
    policy = POLICIES.get(pconfig.name).from_config(pconfig)
    state = torch.load(checkpoint, map_location="cpu", weights_only=False)
    policy.load_state_dict(state["policy"])
    acfg = algo_config_from_dict(config["algo_config"])
    algo = ALGOS.get(acfg.name)(acfg)
    algo.load_state_dict(state["algo"])
    algo.bind(policy)
    algo.set_eval_task(position)
    return policy.eval(), algo
