"""Helpers for the libero_bench tests (imported by tests and conftest): synthetic batches, a policy
server on loopback."""

from __future__ import annotations

import asyncio
import contextlib
import queue
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import torch

if TYPE_CHECKING:
    from libero_bench.rollouts.server import PolicyServer

BatchFactory = Callable[..., dict[str, torch.Tensor]]


def synthetic_batch(
    batch_size: int = 2,
    window: int = 4,
    image_size: int = 32,
    task_emb_dim: int = 384,
    seed: int = 0,
    task_id: int = 0,
) -> dict[str, torch.Tensor]:
    """A batch with the trainer's keys, shapes and value ranges."""
    g = torch.Generator().manual_seed(seed)
    b, t, s = batch_size, window, image_size
    return {
        "agentview": torch.rand(b, t, 3, s, s, generator=g),
        "wrist": torch.rand(b, t, 3, s, s, generator=g),
        "joint_states": torch.randn(b, t, 7, generator=g),
        "gripper_states": torch.randn(b, t, 2, generator=g) * 0.04,
        "task_emb": torch.randn(b, task_emb_dim, generator=g),
        "actions": torch.rand(b, t, 7, generator=g) * 2 - 1,
        "task_id": torch.full((b,), task_id, dtype=torch.long),
    }


def succeeds(environments: Any, policy: Any, jobs: list[Any], on_result: Any = None) -> list[Any]:
    """Stands in for a run's evaluation rounds (``libero_bench.train.rounds.run_round``): every
    rollout succeeds in 3 steps, no simulation (no worker is started)."""
    from libero_bench.rollouts.jobs import RolloutResult

    return [RolloutResult(job.key, True, 3, 0.0) for job in jobs]


def run_request(data: Path, **kwargs: Any) -> Any:
    """A tiny ER run request on ``data`` (one epoch, 32 px, task-id language)."""
    from libero_bench.train.presets import SMOKE
    from libero_bench.train.trainer import RunRequest

    preset = SMOKE.replace(epochs=1, batch_size=32, image_size=32, language_encoder="task_id")
    return RunRequest(data=data, algo="er", policy="resnet_t", preset=preset, **kwargs)


def make_run(data: Path, out: Path) -> Path:
    """A finished run of :func:`run_request` made without simulation (rollouts all succeed)."""
    import pytest

    from libero_bench.train import rounds
    from libero_bench.train.trainer import RunOptions, Trainer, plan_run

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rounds, "run_round", succeeds)
        patch.setattr(Trainer, "collect_rollouts", lambda self, results: None)
        Trainer(plan_run(run_request(data)), out, RunOptions()).run()
    return out


@contextmanager
def on_loopback(server: PolicyServer) -> Iterator[int]:
    """``server`` on a loopback port the system chooses, in a thread; yields the port."""
    loop = asyncio.new_event_loop()
    ports: queue.Queue[int] = queue.Queue()
    task: dict[str, asyncio.Task[None]] = {}

    def run() -> None:
        asyncio.set_event_loop(loop)
        task["serve"] = loop.create_task(server.serve("127.0.0.1", 0, ready=ports.put))
        with contextlib.suppress(asyncio.CancelledError):
            loop.run_until_complete(task["serve"])
        loop.close()

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    try:
        yield ports.get(timeout=60)
    finally:
        loop.call_soon_threadsafe(task["serve"].cancel)
        thread.join(timeout=30)


@contextmanager
def serving(policy: Path) -> Iterator[str]:
    """``libero-bench serve`` of ``policy`` (a run or a LeRobot folder) in this process, on loopback;
    yields its address."""
    from libero_bench.rollouts.server import served_policy

    server = served_policy(str(policy), "cpu")
    try:
        with on_loopback(server) as port:
            yield f"ws://127.0.0.1:{port}"
    finally:
        server.actor.close()
