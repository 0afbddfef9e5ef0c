"""Evaluation rollouts in simulation, run in parallel worker processes; every rollout is kept.

One rollout: build (or reuse) the task's :class:`~libero_data.sim.LiberoEnv` in the worker,
reset it to a fixed stored init state (rollout ``r`` uses init state ``r mod 50`` and
fixture seed ``r``, the same for every epoch and checkpoint), let the scene settle with
``settle`` no-op steps (LIBERO uses 10 before acting), then act with the policy's
``act_step`` until the task's goal holds or ``max_steps`` steps have passed. Success is the
environment's goal predicate, as in LIBERO.

Each rollout is written by the worker that ran it, like a demonstration: a one-episode
LeRobot shard with its MCAP log (:func:`libero_data.record.shard.write_frames`, tagged
with task, learned-after task, epoch, seeds, init index and success) and a Rerun ``.rrd``
(:mod:`libero_bench.rerun_log`). :func:`build_rollout_dataset` joins the shards into one
LeRobot dataset that ``datasets.load_dataset`` reads.

Workers are spawned (a GL context does not survive fork), each builds its own environment
and keeps the last one for the next rollout of the same task; the policy reaches them as a
CPU ``state_dict`` in a file written once per evaluation round. Rendering dominates the
cost (~50 ms per camera frame on a CPU core, two cameras per step).
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor

    from libero_bench.policies import Policy

logger = logging.getLogger(__name__)

CAMERAS = ("agentview", "eye_in_hand")


@dataclass(frozen=True)
class EvalTask:
    """Everything needed to roll a policy out on one task of the run."""

    name: str
    language: str
    position: int  # the task's place in the run's order
    env_ref: str  # a .bddl file (LiberoEnv accepts it)
    task_emb: np.ndarray = field(repr=False)
    init_states: np.ndarray | None = field(default=None, repr=False)  # (n, state_dim) or None

    def start(self, rollout: int) -> tuple[np.ndarray | None, int, int]:
        """(init state, init index, fixture seed) of rollout number ``rollout``."""
        if self.init_states is None or len(self.init_states) == 0:
            return None, -1, rollout
        index = rollout % len(self.init_states)
        return np.asarray(self.init_states[index]), index, rollout


@dataclass(frozen=True)
class RolloutJob:
    """One rollout to run in a worker; ``tags`` end up in the episode's metadata."""

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
    policy_file: str = ""


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
    shard_dir: Path,
    rrd_path: Path,
    tags: Mapping[str, Any],
) -> RolloutJob:
    init_state, init_index, env_seed = task.start(rollout)
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
        tags={**tags, "rollout": rollout, "init_index": init_index, "env_seed": env_seed},
    )


# -- the policy file -----------------------------------------------------------------------------
def save_policy_file(policy: Policy, path: Path) -> Path:
    """Write the policy's type, config and CPU weights for the workers (atomically)."""
    import torch

    state = {k: v.detach().cpu().clone() for k, v in policy.state_dict().items()}
    tmp = path.with_name(path.name + ".tmp")
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save({"config": policy.config.to_dict(), "state_dict": state}, tmp)
    tmp.replace(path)
    return path


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


class RolloutRunner:
    """Runs rollouts in one process, keeping the last environment and policy it loaded."""

    def __init__(self) -> None:
        self._env: Any = None
        self._env_key: tuple[str, int] | None = None
        self._policy: Policy | None = None
        self._policy_file = ""

    def env(self, ref: str, image_size: int) -> Any:
        from libero_data.sim import EnvConfig, LiberoEnv

        key = (ref, image_size)
        if self._env_key != key:
            self.close()
            self._env = LiberoEnv(ref, EnvConfig(image_size=image_size, cameras=CAMERAS))
            self._env_key = key
        return self._env

    def policy(self, path: str) -> Policy:
        if self._policy is None or path != self._policy_file:
            self._policy = load_policy_file(path)
            self._policy_file = path
        return self._policy

    def run(self, job: RolloutJob) -> RolloutResult:
        from libero_bench.rerun_log import write_rollout_rrd
        from libero_data.record.shard import write_frames

        start = time.perf_counter()
        policy = self.policy(job.policy_file)
        env = self.env(job.env_ref, job.image_size)
        policy.reset()
        obs = env.reset(job.init_state, seed=job.env_seed, settle=job.settle)
        frames: list[dict[str, Any]] = []
        success: list[bool] = []
        for _step in range(job.max_steps):
            action = policy.act_step(observation_batch(obs, job.task_emb))[0].numpy()
            action = np.clip(action.astype(np.float64), -1.0, 1.0)
            frame = {k: v for k, v in obs.items() if k != "object_poses"}
            frame["action"] = action.astype(np.float32)
            frames.append(frame)
            obs, ok = env.step(action)
            success.append(bool(ok))
            if ok:
                break
        reached = bool(success and success[-1])
        tags = {**job.tags, "success": reached, "steps": len(frames)}
        write_frames(
            job.shard_dir,
            frames=frames,
            success=success,
            task=job.task_name,
            instruction=job.language,
            image_size=job.image_size,
            sim_state_width=job.sim_state_width,
            info={**tags, "task_name": job.task_name, "language": job.language, "key": job.key},
        )
        write_rollout_rrd(
            job.rrd_path,
            frames=frames,
            success=success,
            language=job.language,
            tags={**tags, "task_name": job.task_name, "key": job.key},
            recording_id=job.key,
        )
        return RolloutResult(job.key, reached, len(frames), time.perf_counter() - start)

    def close(self) -> None:
        if self._env is not None:
            self._env.close()
        self._env, self._env_key = None, None


# -- worker processes -------------------------------------------------------------------------------
_RUNNER: RolloutRunner | None = None  # one per worker process, set by _init_worker


def _init_worker() -> None:
    import ctypes
    import signal
    import sys

    global _RUNNER
    if sys.platform.startswith("linux"):  # die with the run, even when it is SIGKILLed
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("SVT_LOG", "1")
    import torch

    from libero_data.pipeline.memory import limit_malloc_arenas

    limit_malloc_arenas()
    torch.set_num_threads(1)
    _RUNNER = RolloutRunner()


def _run_in_worker(job: RolloutJob) -> RolloutResult:
    assert _RUNNER is not None, "worker was not initialised"
    return _RUNNER.run(job)


# -- Ray ------------------------------------------------------------------------------------------
class RayRollouts:
    """A Ray actor around a :class:`RolloutRunner` (one per worker, kept between rounds).

    It writes each rollout into a scratch folder of its own machine and returns the files,
    so a cluster needs no storage shared with the driver; the policy arrives as bytes.
    """

    def __init__(self) -> None:
        import tempfile

        os.environ.setdefault("OMP_NUM_THREADS", "1")
        os.environ.setdefault("SVT_LOG", "1")
        import torch

        torch.set_num_threads(1)
        self.runner = RolloutRunner()
        self.scratch = Path(tempfile.mkdtemp(prefix="libero-bench-ray-"))
        self.policy_digest = ""

    def run(self, job: RolloutJob, policy_bytes: bytes) -> tuple[RolloutResult, dict[str, bytes], bytes]:
        import hashlib
        import shutil

        from libero_data.record.shard import pack_tree

        digest = hashlib.sha256(policy_bytes).hexdigest()[:16]
        policy_file = self.scratch / f"policy-{digest}.pt"
        if digest != self.policy_digest:
            for old in self.scratch.glob("policy-*.pt"):
                old.unlink()
            policy_file.write_bytes(policy_bytes)
            self.policy_digest = digest
        shard = self.scratch / "shard"
        rrd = self.scratch / "rollout.rrd"
        shutil.rmtree(shard, ignore_errors=True)
        local = dataclasses.replace(
            job, policy_file=str(policy_file), shard_dir=str(shard), rrd_path=str(rrd)
        )
        result = self.runner.run(local)
        return result, pack_tree(shard), rrd.read_bytes()


def _store_rollout(job: RolloutJob, files: dict[str, bytes], rrd: bytes) -> None:
    """Write a rollout that ran elsewhere where a local worker would have written it."""
    from libero_data.record.shard import unpack_tree

    unpack_tree(files, Path(job.shard_dir))
    rrd_path = Path(job.rrd_path)
    rrd_path.parent.mkdir(parents=True, exist_ok=True)
    tmp_rrd = rrd_path.with_name(rrd_path.name + ".tmp")
    tmp_rrd.write_bytes(rrd)
    tmp_rrd.replace(rrd_path)


class Evaluator:
    """Runs rollout jobs with ``workers`` spawned processes (0: in this process), or Ray actors.

    Use as a context manager; the pool lives as long as the evaluator, so workers keep their
    imports and environments between evaluation rounds. With ``executor="ray"`` the rollouts
    run on ``workers`` Ray actors (on the cluster at ``ray_address``, or on a Ray instance
    started here); each rollout depends only on its job, so the results are the same.
    """

    def __init__(
        self, workers: int, work_dir: Path, *, executor: str = "local", ray_address: str | None = None
    ) -> None:
        if workers < 0:
            raise ValueError(f"workers must be >= 0, got {workers}")
        from libero_data.pipeline.ray_runtime import executor_problem

        problem = executor_problem(executor, ray_address)
        if problem is not None:
            raise ValueError(problem[1])
        self.workers = workers
        self.work_dir = Path(work_dir)
        self.executor = executor
        self.ray_address = ray_address
        self._pool: ProcessPoolExecutor | None = None
        self._local: RolloutRunner | None = None
        self._actors: list[Any] = []
        self._ray_started = False
        self._round = 0

    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
        if self._local is not None:
            self._local.close()
            self._local = None
        if self._actors or self._ray_started:
            import ray

            for actor in self._actors:
                ray.kill(actor)
            self._actors = []
            if self._ray_started:
                ray.shutdown()
                self._ray_started = False

    def _ray_actors(self) -> list[Any]:
        if not self._actors:
            from libero_data.pipeline.ray_runtime import start_ray

            ray, self._ray_started = start_ray(self.workers, self.ray_address)
            actor = ray.remote(num_cpus=1)(RayRollouts)
            self._actors = [actor.remote() for _ in range(max(self.workers, 1))]
        return self._actors

    def _run_on_ray(
        self, jobs: Sequence[RolloutJob], policy_file: Path, on_done: Callable[[RolloutResult], None]
    ) -> None:
        import ray

        actors = self._ray_actors()
        policy = ray.put(policy_file.read_bytes())
        by_ref: dict[Any, tuple[RolloutJob, Any]] = {}
        queue = list(jobs)
        idle = list(actors)
        try:
            while queue or by_ref:
                while queue and idle:
                    job, actor = queue.pop(0), idle.pop(0)
                    by_ref[actor.run.remote(job, policy)] = (job, actor)
                done, _ = ray.wait(list(by_ref), num_returns=1)
                job, actor = by_ref.pop(done[0])
                idle.append(actor)
                result, files, rrd = ray.get(done[0])
                _store_rollout(job, files, rrd)
                on_done(result)
        except BaseException:
            for ref in by_ref:
                ray.cancel(ref, force=True)
            raise

    def _executor(self) -> ProcessPoolExecutor:
        if self._pool is None:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            self._pool = ProcessPoolExecutor(
                max_workers=self.workers, mp_context=mp.get_context("spawn"), initializer=_init_worker
            )
        return self._pool

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
        policy_file = save_policy_file(policy, self.work_dir / f"policy-{os.getpid()}-{self._round}.pt")
        jobs = [dataclasses.replace(j, policy_file=str(policy_file)) for j in jobs]
        results: dict[str, RolloutResult] = {}

        def done(result: RolloutResult) -> None:
            results[result.key] = result
            if on_result:
                on_result(result)

        try:
            if self.executor == "ray":
                self._run_on_ray(jobs, policy_file, done)
            elif self.workers == 0:
                if self._local is None:
                    self._local = RolloutRunner()
                for job in jobs:
                    done(self._local.run(job))
            else:
                from concurrent.futures import as_completed

                pool = self._executor()
                futures = [pool.submit(_run_in_worker, job) for job in jobs]
                try:
                    for future in as_completed(futures):
                        done(future.result())
                except BaseException:
                    for future in futures:
                        future.cancel()
                    raise
        finally:
            policy_file.unlink(missing_ok=True)
        return [results[j.key] for j in jobs]


# -- the rollout dataset ------------------------------------------------------------------------------
ROLLOUT_CARD = """---
license: mit
task_categories:
- robotics
tags:
- LeRobot
- LIBERO
- libero-bench
- policy-rollouts
configs:
- config_name: default
  data_files: data/*/*.parquet
---

# Evaluation rollouts of a libero-bench run

Every evaluation rollout of the run `{run}` ({algo} + {policy}, preset `{preset}`, seed {seed}):
{episodes} episodes over {tasks} tasks, recorded like demonstrations (both cameras, 8-D state,
joint positions, gripper state, 7-D actions and the MuJoCo state of every frame).

`meta/libero_episodes.jsonl` tags each episode with its task (`task_name`, `task_position`),
the task learned last when it ran (`learned_after`, `learned_after_position`), the training
epoch (`epoch`; null for the evaluations after later tasks), the phase (`learning`, `after`,
`pruned`), the run seed, the init state (`init_index`, `env_seed`) and `success`.
Each episode has an MCAP log in `mcap/`; the run folder has a Rerun recording per rollout.
"""


def build_rollout_dataset(
    shards: Sequence[Path],
    out: Path,
    *,
    run_meta: Mapping[str, Any],
    bddl: Mapping[str, str],
    work_dir: Path,
) -> int:
    """Join rollout shards (in the given order) into the LeRobot dataset ``out``; returns the
    number of episodes. Built beside ``out`` and swapped in, so ``out`` is always complete."""
    import shutil

    from libero_data.pipeline.snapshot import build_snapshot

    shards = [Path(s) for s in shards]
    if not shards:
        raise ValueError("the run has no rollouts to collect")
    staging = work_dir / "rollouts-staging"
    card = ROLLOUT_CARD.format(
        run=run_meta.get("run", ""),
        algo=run_meta.get("algo", ""),
        policy=run_meta.get("policy", ""),
        preset=run_meta.get("preset", ""),
        seed=run_meta.get("seed", ""),
        episodes=len(shards),
        tasks=len(bddl),
    )
    from libero_data.record.shard import quiet_datasets

    with quiet_datasets():
        build_snapshot(
            shards,
            staging,
            repo_id="libero-bench/rollouts",
            snapshot_id=f"rollouts-{len(shards)}",
            dataset_meta=dict(run_meta),
            bddl=dict(bddl),
            card=card,
        )
    old = work_dir / "rollouts-old"
    if old.exists():
        shutil.rmtree(old)
    if out.exists():
        out.rename(old)
    staging.rename(out)
    if old.exists():
        shutil.rmtree(old)
    return len(shards)
