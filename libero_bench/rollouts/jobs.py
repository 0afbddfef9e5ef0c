"""What one evaluation rollout is: its task, its start and its settings (a job), and its result.

Starts come in two kinds, the same for every epoch, checkpoint, run and method: *stored*
(``libero_data.seeding.rollout_start``: rollout ``r`` from LIBERO's stored init state
``r mod 50`` with fixture seed ``r``, the paper's protocol) and *held out* (placements LIBERO's
sampler draws from the task's held-out seed stream, skipping any seed a demonstration of the
task started from). A rollout's start is a function of its job only.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.runs.folder import HELDOUT, STORED
from libero_data.seeding import rollout_start
from libero_data.sim.arm import ARM_INIT_NOISE
from libero_data.tasks.horizons import StepLimit, step_limit


@dataclass(frozen=True)
class EvalTask:
    """Everything needed to roll a policy out on one task of the run.

    ``heldout`` are the seeds of its held-out starts (``libero_data.seeding.heldout_starts``:
    LIBERO's sampler places objects and fixtures from each; none is a seed a demonstration of
    the task started from).
    """

    name: str
    language: str
    position: int  # the task's place in the run's order
    env_ref: str  # a .bddl file (LiberoEnv accepts it)
    task_emb: np.ndarray = field(repr=False)
    init_states: np.ndarray | None = field(default=None, repr=False)  # (n, state_dim) or None
    heldout: tuple[int, ...] = ()
    suite: str = ""  # the task's suite: its step limit when rollouts take the suite's

    def start(self, rollout: int, start: str = STORED) -> tuple[np.ndarray | None, int, int]:
        """(init state, init index, seed) of rollout number ``rollout`` from a ``start`` kind."""
        if start == HELDOUT:
            return None, -1, self.heldout[rollout]
        stored = 0 if self.init_states is None else len(self.init_states)
        index, seed = rollout_start(rollout, stored)
        if index < 0 or self.init_states is None:
            return None, -1, seed
        return np.asarray(self.init_states[index]), index, seed


@dataclass(frozen=True)
class RolloutJob:
    """One rollout to run; ``shard_dir`` and ``rrd_path`` are relative to the evaluator's
    folder, and ``tags`` end up in the episode's metadata."""

    key: str
    env_ref: str
    task_name: str
    language: str
    task_emb: np.ndarray = field(repr=False)
    init_state: np.ndarray | None = field(repr=False)
    init_index: int
    env_seed: int
    settle: int
    max_steps: int
    image_size: int
    sim_state_width: int
    shard_dir: str
    rrd_path: str
    tags: Mapping[str, Any]
    start: str = STORED
    render_quality: str = "full"
    arm_noise: float = ARM_INIT_NOISE  # rad per arm joint on held-out (sampler) starts


@dataclass(frozen=True)
class RolloutResult:
    key: str
    success: bool
    steps: int
    seconds: float


def make_job(
    task: EvalTask,
    rollout: int,
    *,
    key: str,
    settle: int,
    max_steps: StepLimit,
    image_size: int,
    sim_state_width: int,
    shard_dir: str | Path,
    rrd_path: str | Path,
    tags: Mapping[str, Any],
    start: str = STORED,
    render_quality: str = "full",
    arm_noise: float = ARM_INIT_NOISE,
) -> RolloutJob:
    """Rollout number ``rollout`` of ``task`` from a ``start`` kind; ``max_steps`` a number of
    steps or ``"suite"`` (the task's suite's limit, :mod:`libero_data.tasks.horizons`), recorded
    in the rollout's tags either way."""
    init_state, init_index, env_seed = task.start(rollout, start)
    limit = step_limit(max_steps, task.suite)
    return RolloutJob(
        key=key,
        env_ref=task.env_ref,
        task_name=task.name,
        language=task.language,
        task_emb=np.asarray(task.task_emb, dtype=np.float32),
        init_state=init_state,
        init_index=init_index,
        env_seed=env_seed,
        settle=settle,
        max_steps=limit,
        image_size=image_size,
        sim_state_width=sim_state_width,
        shard_dir=str(shard_dir),
        rrd_path=str(rrd_path),
        tags={
            **tags,
            "rollout": rollout,
            "start": start,
            "init_index": init_index,
            "env_seed": env_seed,
            "max_steps": limit,
        },
        start=start,
        render_quality=render_quality,
        arm_noise=arm_noise,
    )
