"""The worker side of evaluation: environments that start, step and store rollouts.

An :class:`EpisodeHost` lives in a worker (one per process or Ray actor, built by
:func:`make_host`) and holds the environments of some *slots*, each running one episode at a
time. The driver sends, per control step, the jobs to start and the actions of the running
episodes (:meth:`EpisodeHost.advance`); the host answers each slot with its next observation, or,
when the goal holds or the step limit is reached, with the episode's result, after writing it like
a demonstration: a one-episode LeRobot shard with its MCAP log
(:func:`libero_data.record.shard.write_frames`, tagged with the job's tags, seeds, init index and
success) and a Rerun ``.rrd`` (:mod:`libero_bench.rollouts.rerun_log`).

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
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from libero_bench.rollouts.jobs import RolloutJob, RolloutResult
    from libero_data.runtime.jobs import WorkerContext

CAMERAS = ("agentview", "eye_in_hand")
#: What storing an episode imports (LeRobot's dataset writer, the video encoder, Rerun).
STORE_MODULES = (
    "lerobot.datasets.lerobot_dataset",
    "lerobot.datasets.video_utils",
    "av",
    "rerun",
    "datasets",
)
#: The rollouts' video codec: H.264 (x264 ``veryfast``, CRF 20) where demonstrations have
#: LeRobot's AV1 (SVT-AV1, CRF 30). A rollout is written while the evaluation runs, on the CPU
#: its environments step on; on one 290-frame rollout of two 256 px cameras (images new every
#: 5th step) it costs 0.92 CPU-seconds against AV1's 3.44, at a PSNR to the drawn frames of
#: 39.7 / 39.8 dB against 38.4 / 37.8, files 43% smaller (benchmarks/RESULTS.md, "Rollout
#: videos: H.264 against AV1").
#: Key frames where the images are new: the first new image at least ROLLOUT_KEY_SPACING frames
#: after the last key frame starts one, a held image never does (the codec's own GOP, ``g``, is
#: a cap only). With a new image every step that is LeRobot's key frame every 2 frames; with images
#: held through a chunk, one key frame per new image instead of one every other frame (1.12
#: CPU-s and 3.48 MB that rollout; RESULTS, same section). Training still reads any frame fast
#: (2.0 ms against 1.8): it decodes from its key frame through the held copies.
ROLLOUT_VIDEO = {"vcodec": "h264", "preset": "veryfast", "crf": 20, "g": 40, "pix_fmt": "yuv420p"}
ROLLOUT_KEY_SPACING = 2


def rollout_encoder() -> Any:
    """LeRobot's encoder settings for rollout videos (:data:`ROLLOUT_VIDEO`)."""
    from lerobot.configs.video import RGBEncoderConfig

    return RGBEncoderConfig(**ROLLOUT_VIDEO)


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
    held: int = 0  # observations whose images were held from the step before (nobody looked)


class EpisodeHost:
    """The environments of a worker's slots (see the module docstring)."""

    def __init__(self, ctx: WorkerContext) -> None:
        self.ctx = ctx
        self.running: dict[int, Episode] = {}
        self.warmed = False
        self._writer: ThreadPoolExecutor | None = None
        self._writing: list[Future[tuple[str, ...]]] = []
        self.store_seconds = 0.0

    def advance(
        self,
        starts: Mapping[int, RolloutJob],
        actions: Mapping[int, np.ndarray],
        unseen: frozenset[int] = frozenset(),
    ) -> dict[int, Reply]:
        """Step the running slots with ``actions``, then start ``starts``; each slot's reply.

        A slot's actions are one 7-D action or several ``(k, 7)`` in a row (a chunk's actions that
        the policy takes without looking): the steps before the last draw no images, and the
        episode stops at the first step that ends it. The slots in ``unseen`` draw no images at
        their last step either: the policy will not look at this observation (it acts from a
        queued chunk), and the images drawn last are held in its place."""
        self._collect(wait=False)
        replies: dict[int, Reply] = {}
        for slot, given in actions.items():
            rows = np.asarray(given, dtype=np.float64).reshape(-1, np.shape(given)[-1])
            for i, action in enumerate(rows):
                last = i == len(rows) - 1
                replies[slot] = self.step(slot, action, render=last and slot not in unseen)
                if replies[slot][1] is not None:  # the episode ended
                    break
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
        if not self.warmed:  # imported while the first episode runs (not while its scene is built)
            from libero_data.runtime.warm import warm_imports

            warm_imports(STORE_MODULES)
            self.warmed = True
        episode = self.running[slot] = Episode(job, env, obs, started)
        episode.phases["build_s"] = built - started
        episode.phases["reset_s"] = time.perf_counter() - built
        return policy_view(obs)

    def step(self, slot: int, action: np.ndarray, *, render: bool = True) -> Reply:
        """Apply one action; the next observation, or the result once the episode ends (without
        ``render``: the observation holds the images drawn last)."""
        episode = self.running[slot]
        action = np.clip(np.asarray(action, dtype=np.float64).reshape(-1), -1.0, 1.0)
        frame = policy_view(episode.obs)
        frame["action"] = action.astype(np.float32)
        episode.frames.append(frame)
        stepped = time.perf_counter()
        before = episode.obs
        episode.obs, ok = episode.env.step(action, render=render)
        if not render:
            episode.held += 1
            for camera in CAMERAS:
                episode.obs.setdefault(camera, before[camera])
        episode.phases["step_s"] += time.perf_counter() - stepped
        episode.success.append(bool(ok))
        if ok or len(episode.frames) >= episode.job.max_steps:
            del self.running[slot]
            return None, self.finish(episode)
        return policy_view(episode.obs), None

    def finish(self, episode: Episode) -> RolloutResult:
        """The finished episode's result; it is written by this worker's writer thread while the
        environments go on (a store would otherwise hold every environment of the step back)."""
        from libero_bench.rollouts.jobs import RolloutResult

        if self._writer is None:
            self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="store")
        self._writing.append(self._writer.submit(self.store, episode))
        reached = bool(episode.success and episode.success[-1])
        done = time.perf_counter()
        return RolloutResult(
            episode.job.key, reached, len(episode.frames), done - episode.started, episode.phases
        )

    def flush(self) -> float:
        """Wait until every finished episode is written; the seconds writing took since the last flush."""
        self._collect(wait=True)
        seconds, self.store_seconds = self.store_seconds, 0.0
        return seconds

    def _collect(self, *, wait: bool) -> None:
        """Ship what the writer has written (raising what it failed on), from this thread."""
        keep = []
        for future in self._writing:
            if wait or future.done():
                for path in future.result():
                    self.ctx.ship(path)
            else:
                keep.append(future)
        self._writing = keep

    def store(self, episode: Episode) -> tuple[str, ...]:
        """Write a finished episode like a demonstration (shard, MCAP log, Rerun recording); the
        paths written (relative to the root)."""
        from libero_bench.rollouts.rerun_log import write_rollout_rrd
        from libero_data.record.features import FeatureLayout
        from libero_data.record.mcap_log import episode_jpegs
        from libero_data.record.shard import write_frames
        from libero_data.runtime.memory import release_free_memory

        job, frames, success = episode.job, episode.frames, episode.success
        storing = time.perf_counter()
        reached = bool(success and success[-1])
        tags = {**job.tags, "success": reached, "steps": len(frames), "task_name": job.task_name}
        if episode.held:  # the images are the policy's view: drawn when it looked, held between
            tags["held_images"] = episode.held
        jpegs = episode_jpegs()  # one JPEG per image for the MCAP log and the Rerun recording
        write_frames(
            self.ctx.root / job.shard_dir,
            frames=frames,
            success=success,
            task=job.task_name,
            instruction=job.language,
            layout=FeatureLayout(image_size=job.image_size),
            sim_state_width=job.sim_state_width,
            info={**tags, "language": job.language, "key": job.key},
            rgb_encoder=rollout_encoder(),
            key_spacing=ROLLOUT_KEY_SPACING,
            jpegs=jpegs,
        )
        write_rollout_rrd(
            self.ctx.root / job.rrd_path,
            frames=frames,
            success=success,
            language=job.language,
            tags={**tags, "key": job.key},
            recording_id=job.key,
            jpegs=jpegs,
        )
        release_free_memory()  # between episodes, as the job runner's workers do
        self.store_seconds += time.perf_counter() - storing
        return job.shard_dir, job.rrd_path

    def abandon(self) -> None:
        """Forget the running episodes (an interrupted evaluation: they are run again on resume);
        the finished ones are written first."""
        self.running.clear()
        self.flush()


def make_host(ctx: WorkerContext) -> EpisodeHost:
    """The actor factory of :class:`~libero_data.runtime.actors.ActorPool`."""
    return EpisodeHost(ctx)
