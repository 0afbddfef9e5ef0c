"""The worker side of evaluation: environments that start, step and store rollouts.

An :class:`EpisodeHost` lives in a worker (one per process or Ray actor, built by
:func:`make_host`) and holds the environments of some *slots*, each running one episode at a
time. The driver sends, per control step, the jobs to start and the actions of the running
episodes (:meth:`EpisodeHost.advance`); the host answers each slot with its next observation, or,
when the goal holds or the step limit is reached, with the episode's result, after writing it like
a demonstration: a one-episode LeRobot shard with its MCAP log
(:func:`libero_data.record.shard.write_frames`, tagged with the job's tags, seeds, init index and
success) and a Rerun ``.rrd`` (:mod:`libero_bench.evaluation.rerun_log`).

One rollout: take (or build) the task's :class:`~libero_data.sim.LiberoEnv`, reset it to the job's
start, let the scene settle with ``settle`` no-op steps (LIBERO waits 10 before acting), then act
until the task's goal holds or ``max_steps`` steps have passed. Success is the environment's goal
predicate, as in LIBERO. A standard start (``job.libero_loop``) runs LIBERO's own loop on the
environment instead (:class:`~libero_data.sim.libero_loop.LiberoLoop`: LIBERO's reset, start, step
and ``done``). Each slot keeps its environment between episodes of the same task.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from libero_bench.rollouts.jobs import RolloutJob, RolloutResult
    from libero_data.runtime.jobs import WorkerContext

CAMERAS = ("agentview", "eye_in_hand")
#: Observation entries the policy side never reads (the driver gets everything else).
NOT_SENT = ("object_poses",)

#: A slot's answer to one call: its next observation, or the finished episode's result.
Reply = tuple[dict[str, Any] | None, "RolloutResult | None"]


def policy_view(obs: Mapping[str, Any]) -> dict[str, Any]:
    """The observation as the driver gets it."""
    return {k: v for k, v in obs.items() if k not in NOT_SENT}


@dataclass
class Episode:
    """One running rollout: its job, frames so far and per-step success."""

    job: RolloutJob
    env: Any
    obs: dict[str, Any]
    started: float
    frames: list[dict[str, Any]] = field(default_factory=list)
    success: list[bool] = field(default_factory=list)
    phases: dict[str, float] = field(default_factory=lambda: {"build_s": 0.0, "reset_s": 0.0, "step_s": 0.0})


class EpisodeHost:
    """The environments of a worker's slots (see the module docstring)."""

    def __init__(self, ctx: WorkerContext) -> None:
        self.ctx = ctx
        self.running: dict[int, Episode] = {}

    def advance(
        self, starts: Mapping[int, RolloutJob], actions: Mapping[int, np.ndarray]
    ) -> dict[int, Reply]:
        """Step the running slots with ``actions``, then start ``starts``; each slot's reply."""
        replies: dict[int, Reply] = {slot: self.step(slot, action) for slot, action in actions.items()}
        for slot, job in starts.items():
            replies[slot] = (self.start(slot, job), None)
        return replies

    def environment(self, slot: int, job: RolloutJob) -> Any:
        """The slot's environment for the job's task (both cameras at the job's size and quality)."""
        from libero_data.sim import EnvConfig, LiberoEnv

        config = EnvConfig(
            image_size=job.image_size,
            cameras=CAMERAS,
            render_quality=job.render_quality,
            arm_noise=job.arm_noise,
        )

        def build() -> Any:
            env = LiberoEnv(job.env_ref, config)
            if not job.libero_loop:
                return env
            from libero_data.sim.libero_loop import LiberoLoop

            return LiberoLoop(env, seed=job.env_seed)

        loop_seed = job.env_seed if job.libero_loop else None
        return self.ctx.cache.get(
            f"env-{slot}",
            (job.env_ref, job.image_size, job.render_quality, job.arm_noise, loop_seed),
            build,
            close=lambda e: e.close(),
        )

    def start(self, slot: int, job: RolloutJob) -> dict[str, Any]:
        """Reset the slot's environment to the job's start; its first observation."""
        if slot in self.running:
            raise RuntimeError(f"slot {slot} is still running {self.running[slot].job.key}")
        started = time.perf_counter()
        env = self.environment(slot, job)
        built = time.perf_counter()
        if job.libero_loop:
            assert job.init_state is not None, "a standard start has a stored init state"
            obs = env.reset(job.init_state, job.init_index, settle=job.settle)
        else:
            obs = env.reset(job.init_state, seed=job.env_seed, settle=job.settle)
        episode = self.running[slot] = Episode(job, env, obs, started)
        episode.phases["build_s"] = built - started
        episode.phases["reset_s"] = time.perf_counter() - built
        return policy_view(obs)

    def step(self, slot: int, action: np.ndarray) -> Reply:
        """Apply one action; the next observation, or the result once the episode ends."""
        episode = self.running[slot]
        action = np.clip(np.asarray(action, dtype=np.float64).reshape(-1), -1.0, 1.0)
        frame = policy_view(episode.obs)
        frame["action"] = action.astype(np.float32)
        episode.frames.append(frame)
        stepped = time.perf_counter()
        episode.obs, ok = episode.env.step(action)
        episode.phases["step_s"] += time.perf_counter() - stepped
        episode.success.append(bool(ok))
        if ok or len(episode.frames) >= episode.job.max_steps:
            del self.running[slot]
            return None, self.store(episode)
        return policy_view(episode.obs), None

    def store(self, episode: Episode) -> RolloutResult:
        """Write a finished episode like a demonstration (shard, MCAP log, Rerun recording)."""
        from libero_bench.evaluation.rerun_log import write_rollout_rrd
        from libero_bench.rollouts.jobs import RolloutResult
        from libero_data.record.features import FeatureLayout
        from libero_data.record.shard import write_frames
        from libero_data.runtime.memory import release_free_memory

        job, frames, success = episode.job, episode.frames, episode.success
        storing = time.perf_counter()
        reached = bool(success and success[-1])
        tags = {**job.tags, "success": reached, "steps": len(frames), "task_name": job.task_name}
        write_frames(
            self.ctx.root / job.shard_dir,
            frames=frames,
            success=success,
            task=job.task_name,
            instruction=job.language,
            layout=FeatureLayout(image_size=job.image_size),
            sim_state_width=job.sim_state_width,
            info={**tags, "language": job.language, "key": job.key},
        )
        write_rollout_rrd(
            self.ctx.root / job.rrd_path,
            frames=frames,
            success=success,
            language=job.language,
            tags={**tags, "key": job.key},
            recording_id=job.key,
        )
        self.ctx.ship(job.shard_dir)
        self.ctx.ship(job.rrd_path)
        release_free_memory()  # between episodes, as the job runner's workers do
        done = time.perf_counter()
        phases = {**episode.phases, "store_s": done - storing}
        return RolloutResult(job.key, reached, len(frames), done - episode.started, phases)

    def abandon(self) -> None:
        """Forget the running episodes (an interrupted evaluation: they are run again on resume)."""
        self.running.clear()


def make_host(ctx: WorkerContext) -> EpisodeHost:
    """The actor factory of :class:`~libero_data.runtime.actors.ActorPool`."""
    return EpisodeHost(ctx)
