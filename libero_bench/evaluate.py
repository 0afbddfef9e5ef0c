"""Evaluation rollouts in simulation, run as jobs of the runtime's job runner; every rollout is kept.

One rollout: take (or build) the task's :class:`~libero_data.sim.LiberoEnv` from the worker's
cache, reset it to a fixed start, let the scene settle with ``settle`` no-op steps (LIBERO waits 10 before acting), then act with the
policy's ``act_step`` until the task's goal holds or ``max_steps`` steps have passed. Success
is the environment's goal predicate, as in LIBERO.

Starts come in two kinds, the same for every epoch, checkpoint, run and method: *stored*
(``libero_data.seeding.rollout_start``: rollout ``r`` from LIBERO's stored init state
``r mod 50`` with fixture seed ``r``, the paper's protocol) and *held out* (placements LIBERO's
sampler draws from the task's held-out seed stream, skipping any seed a demonstration of the
task started from).

Each rollout is written by the job that ran it, like a demonstration: a one-episode LeRobot
shard with its MCAP log (:func:`libero_data.record.shard.write_frames`, tagged with task,
learned-after task, epoch, seeds, init index and success) and a Rerun ``.rrd``
(:mod:`libero_bench.rerun_log`); :mod:`libero_bench.rollout_dataset` joins the shards into one
LeRobot dataset. The policy reaches the workers as a shared file (its type, config and CPU
weights) written once per evaluation round; workers keep the last environment and policy they
loaded. Rendering dominates the cost (~50 ms per camera frame on a CPU core, two cameras).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_bench.run_files import HELDOUT, STORED
from libero_data.runtime.jobs import Executor, JobRunner, WorkerContext
from libero_data.seeding import rollout_start
from libero_data.sim.arm import ARM_INIT_NOISE

if TYPE_CHECKING:
    from libero_bench.policies import Policy

CAMERAS = ("agentview", "eye_in_hand")


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
    max_steps: int,
    image_size: int,
    sim_state_width: int,
    shard_dir: str | Path,
    rrd_path: str | Path,
    tags: Mapping[str, Any],
    start: str = STORED,
    render_quality: str = "full",
    arm_noise: float = ARM_INIT_NOISE,
) -> RolloutJob:
    init_state, init_index, env_seed = task.start(rollout, start)
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
        max_steps=max_steps,
        image_size=image_size,
        sim_state_width=sim_state_width,
        shard_dir=str(shard_dir),
        rrd_path=str(rrd_path),
        tags={**tags, "rollout": rollout, "start": start, "init_index": init_index, "env_seed": env_seed},
        start=start,
        render_quality=render_quality,
        arm_noise=arm_noise,
    )


# -- the policy file -----------------------------------------------------------------------------
def save_policy_file(policy: Policy, path: Path) -> Path:
    """Write the policy's type, config and CPU weights for the workers (atomically)."""
    import io

    import torch

    from libero_data.runtime.files import write_bytes

    state = {k: v.detach().cpu().clone() for k, v in policy.state_dict().items()}
    buffer = io.BytesIO()
    torch.save({"config": policy.config.to_dict(), "state_dict": state}, buffer)
    return write_bytes(path, buffer.getvalue())


def load_policy_file(path: str | Path) -> Policy:
    import torch

    from libero_bench.policies import POLICIES, config_from_dict

    data = torch.load(path, map_location="cpu", weights_only=True)
    config = config_from_dict(data["config"])
    policy = POLICIES.get(config.name).from_config(config)
    policy.load_state_dict(data["state_dict"])
    return policy.eval()


# -- one rollout -----------------------------------------------------------------------------------
def observation_batch(obs: Mapping[str, Any], task_emb: np.ndarray) -> dict[str, Any]:
    """A one-frame policy batch (B = T = 1) from an environment observation."""
    import torch

    from libero_bench.batch_keys import AGENTVIEW, GRIPPER_STATES, JOINT_STATES, TASK_EMB, WRIST

    def image(key: str) -> torch.Tensor:
        array = np.ascontiguousarray(obs[key])
        return torch.from_numpy(array).permute(2, 0, 1).float().div_(255.0)[None, None]

    return {
        AGENTVIEW: image("agentview"),
        WRIST: image("eye_in_hand"),
        JOINT_STATES: torch.as_tensor(np.asarray(obs["joint_pos"], dtype=np.float32))[None, None],
        GRIPPER_STATES: torch.as_tensor(np.asarray(obs["gripper_state"], dtype=np.float32))[None, None],
        TASK_EMB: torch.as_tensor(np.asarray(task_emb, dtype=np.float32))[None],
    }


def rollout_env(ctx: WorkerContext, job: RolloutJob) -> Any:
    """The job's task environment (both cameras at the job's size and quality), kept by the worker."""
    from libero_data.sim import EnvConfig, LiberoEnv

    config = EnvConfig(
        image_size=job.image_size, cameras=CAMERAS, render_quality=job.render_quality, arm_noise=job.arm_noise
    )
    return ctx.cache.get(
        "env",
        (job.env_ref, job.image_size, job.render_quality, job.arm_noise),
        lambda: LiberoEnv(job.env_ref, config),
        close=lambda e: e.close(),
    )


def roll_out_and_store(
    ctx: WorkerContext, job: RolloutJob, act: Callable[[dict[str, Any]], np.ndarray]
) -> RolloutResult:
    """One rollout of ``act`` (an environment observation -> a 7-D action), stored like a
    demonstration (shard, MCAP log, Rerun recording)."""
    from libero_bench.rerun_log import write_rollout_rrd
    from libero_data.record.features import FeatureLayout
    from libero_data.record.shard import write_frames

    start = time.perf_counter()
    env = rollout_env(ctx, job)
    obs = env.reset(job.init_state, seed=job.env_seed, settle=job.settle)
    frames: list[dict[str, Any]] = []
    success: list[bool] = []
    for _step in range(job.max_steps):
        action = np.clip(np.asarray(act(obs), dtype=np.float64).reshape(-1), -1.0, 1.0)
        frame = {k: v for k, v in obs.items() if k != "object_poses"}
        frame["action"] = action.astype(np.float32)
        frames.append(frame)
        obs, ok = env.step(action)
        success.append(bool(ok))
        if ok:
            break
    reached = bool(success and success[-1])
    tags = {**job.tags, "success": reached, "steps": len(frames), "task_name": job.task_name}
    write_frames(
        ctx.root / job.shard_dir,
        frames=frames,
        success=success,
        task=job.task_name,
        instruction=job.language,
        layout=FeatureLayout(image_size=job.image_size),
        sim_state_width=job.sim_state_width,
        info={**tags, "language": job.language, "key": job.key},
    )
    write_rollout_rrd(
        ctx.root / job.rrd_path,
        frames=frames,
        success=success,
        language=job.language,
        tags={**tags, "key": job.key},
        recording_id=job.key,
    )
    ctx.ship(job.shard_dir)
    ctx.ship(job.rrd_path)
    return RolloutResult(job.key, reached, len(frames), time.perf_counter() - start)


def run_rollout(ctx: WorkerContext, job: RolloutJob) -> RolloutResult:
    """Roll the shared policy (one of libero-bench's) out once and store the rollout."""
    assert ctx.shared is not None, "rollouts need the policy file"
    policy_file = ctx.shared
    policy = ctx.cache.get("policy", str(policy_file), lambda: load_policy_file(policy_file))
    policy.reset()
    return roll_out_and_store(
        ctx, job, lambda obs: policy.act_step(observation_batch(obs, job.task_emb))[0].numpy()
    )


def worker_setup() -> None:
    """Once per worker process: one torch thread (rollouts run side by side)."""
    import torch

    torch.set_num_threads(1)


class Evaluator:
    """Runs rollout jobs with ``workers`` processes (0: in this process) or on Ray; rollouts
    are written under ``root``. A context manager: workers keep their imports, environment and
    policy between evaluation rounds. Each rollout depends only on its job, so the results do
    not depend on the executor or the number of workers."""

    def __init__(
        self, workers: int, root: Path, *, executor: str = "local", ray_address: str | None = None
    ) -> None:
        self.root = Path(root)
        self.runner = JobRunner(Executor(executor, workers, ray_address), self.root, setup=worker_setup)
        self._round = 0

    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, kind: object, error: object, tb: object) -> None:
        self.runner.close(abort=error is not None)

    def run(
        self,
        policy: Policy,
        jobs: Sequence[RolloutJob],
        on_result: Callable[[RolloutResult], None] | None = None,
    ) -> list[RolloutResult]:
        """Run ``jobs`` with the policy's current weights; results in the order of ``jobs``."""
        if not jobs:
            return []
        self._round += 1
        policy_file = save_policy_file(policy, self.root / ".work" / f"policy-{os.getpid()}-{self._round}.pt")
        results: dict[int, RolloutResult] = {}
        try:
            for i, result in self.runner.run(run_rollout, jobs, shared=policy_file):
                results[i] = result
                if on_result:
                    on_result(result)
        finally:
            policy_file.unlink(missing_ok=True)
        return [results[i] for i in range(len(jobs))]
