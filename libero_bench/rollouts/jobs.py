"""What one evaluation rollout is: its task, its start and its settings (a job), and its result.

Starts come in three kinds, the same for every epoch, checkpoint, run and method: *stored*
(``libero_data.seeding.rollout_start``: rollout ``r`` from LIBERO's stored init state
``r mod 50`` with fixture seed ``r``), *held out* (placements LIBERO's sampler draws from the
task's held-out seed stream, skipping any seed a demonstration of the task started from), and
*standard* (the standard protocol's: rollout ``r`` from stored init state ``r``, its fixtures
where LIBERO's ``r``-th reset after seeding with 7 puts them; :mod:`libero_data.sim.libero_loop`).
A rollout's start is a function of its job only.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.runs.folder import HELDOUT, STANDARD, STORED
from libero_data.errors import InputError
from libero_data.seeding import rollout_start
from libero_data.sim.arm import ARM_INIT_NOISE
from libero_data.sim.libero_loop import LIBERO_LOOP_SEED
from libero_data.tasks.horizons import SUITE_LIMITS, StepLimit, step_limit


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
        if start == STANDARD:
            if self.init_states is None or rollout >= stored:
                raise InputError(
                    f"task {self.name} has {stored} stored init states; the standard protocol's episode "
                    f"{rollout} starts from init state {rollout}",
                    field="trials",
                )
            return np.asarray(self.init_states[rollout]), rollout, LIBERO_LOOP_SEED
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
    libero_loop: bool = False  # LIBERO's own loop (a standard start): env_seed seeds it once per task
    suite: str = ""  # the task's suite (openpi's episode messages name it)


@dataclass(frozen=True)
class RolloutResult:
    """A finished rollout; ``phases`` are the worker's seconds in each phase of it (building its
    environment, resetting it, stepping it, storing the episode)."""

    key: str
    success: bool
    steps: int
    seconds: float
    phases: Mapping[str, float] = field(default_factory=dict)


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
    limits: Mapping[str, int] = SUITE_LIMITS,
) -> RolloutJob:
    """Rollout number ``rollout`` of ``task`` from a ``start`` kind; ``max_steps`` a number of
    steps or ``"suite"`` (the task's suite's entry in ``limits``, :mod:`libero_data.tasks.horizons`),
    recorded in the rollout's tags either way. A standard start runs LIBERO's own loop."""
    init_state, init_index, env_seed = task.start(rollout, start)
    limit = step_limit(max_steps, task.suite, limits)
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
        libero_loop=start == STANDARD,
        suite=task.suite,
    )
