"""Making one task's episodes (the job ``generate`` runs in its workers): search, then record.

For each slot the request's demonstration source (:mod:`~libero_data.pipeline.sources`) makes
its record (the expert searches without cameras, retrying with new seeds until an attempt
succeeds); the record is saved at once, unless the source wrote it before the job (an import).
The kept episode is then re-rendered from its states and written as a one-episode shard with its
MCAP log. Both are files under the work folder: ``search/<key>.npz`` and ``shards/<key>/``.
"""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.errors import DatasetError
from libero_data.pipeline.request import GenerateRequest, Slot
from libero_data.pipeline.sources import EpisodeRecord, source_of
from libero_data.record.features import CAMERAS
from libero_data.runtime.files import write_bytes
from libero_data.runtime.jobs import WorkerCache, WorkerContext
from libero_data.sim.arm import ARM_INIT_NOISE

#: The fingerprint of an episode searched before fingerprints were recorded.
UNKNOWN_MACHINE: dict[str, Any] = {"numeric_key": "unknown"}


def search_path(key: str) -> Path:
    """Where a slot's search record lives (by the slot's key), relative to the work folder."""
    return Path("search") / f"{key}.npz"


def shard_path(key: str) -> Path:
    """Where a slot's shard lives (by the slot's key), relative to the work folder."""
    return Path("shards") / key


@dataclass(frozen=True)
class EpisodeJob:
    """Some episode numbers of one task, as a worker gets them."""

    request: GenerateRequest
    position: int  # the task's place in the request
    task_index: int  # its index in the suite
    ks: tuple[int, ...]
    sim_state_width: int
    #: Search records written before the job (``import``, ``rerender``), as (slot key, npz
    #: bytes), for a worker that does not share the driver's files (Ray): written into its
    #: folder before the job starts.
    records: tuple[tuple[str, bytes], ...] = ()


@dataclass(frozen=True)
class EpisodeDone:
    """Reported as each episode is finished (its shard on disk) or given up."""

    key: str
    k: int
    success: bool
    attempts: int
    too_long: int = 0  # attempts stopped at the length bound (EpisodeRecord.too_long)
    length: int = 0  # the kept episode's steps to its goal (0: given up)


def done_event(slot: Slot, record: EpisodeRecord) -> EpisodeDone:
    """What is reported of a slot once its record (and a kept episode's shard) is on disk."""
    kept = record.actions if record.success else None
    length = 0 if kept is None else record.goal_step or len(kept)  # steps to the goal, not after it
    return EpisodeDone(slot.key, slot.k, record.success, record.attempts, record.too_long, length)


def expert_env(
    cache: WorkerCache,
    task: Any,
    image_size: int,
    cameras: tuple[str, ...] = CAMERAS,
    render_quality: str = "full",
    arm_noise: float = ARM_INIT_NOISE,
    max_steps: int | None = None,
) -> tuple[Any, Any]:
    """(env, expert) of ``task`` at ``image_size`` from the worker's cache, built when it changed.

    Episodes do not depend on what ran before them in an environment (``reset`` and
    ``set_state`` put everything that shapes a trajectory in a canonical form), so keeping one
    between jobs changes no result; and a rebuild is not free: the first one in a process
    leaves resident memory behind that closing the old environment does not give back.
    ``max_steps`` stops the expert's attempts there (the length bound; None: the expert's own
    budget); the actions before it are the same either way.
    """
    from libero_data.experts.expert import Expert, ExpertConfig
    from libero_data.sim import EnvConfig, LiberoEnv

    def build() -> tuple[Any, Any]:
        config = EnvConfig(
            image_size=image_size, cameras=cameras, render_quality=render_quality, arm_noise=arm_noise
        )
        env = LiberoEnv(task, config)
        expert = ExpertConfig() if max_steps is None else ExpertConfig(max_steps=max_steps)
        return env, Expert(env, expert)

    key = (str(task.suite), int(task.index), int(image_size), cameras, render_quality, arm_noise, max_steps)
    return cache.get("env", key, build, close=lambda pair: pair[0].close())


def episode_info(task: Any, slot: Slot, record: EpisodeRecord, gl: dict[str, str]) -> dict[str, Any]:
    """What a kept episode's ``episode.json`` says about it, beside its frames."""
    states, _actions = record.trajectory()
    return {
        "slot": slot.key,
        "suite": task.suite,
        "task_index": task.index,
        "task_name": task.name,
        "language": task.language,
        "init_index": int(record.init_index),
        "reset_seed": int(record.reset_seed),
        "expert_seed": int(record.expert_seed),
        "attempt": int(record.attempts) - 1,
        "sim_state_dim": int(states.shape[1]),
        "plan": list(record.plan),
        # The code that made the episode (a run resumed after an update of the expert or
        # simulator keeps the episodes found before it).
        "expert_code": record.code,
        # The numeric path that made it (what a replay must match bit for bit) and the
        # OpenGL renderer that drew its images.
        "machine": record.machine or UNKNOWN_MACHINE,
        "gl": gl,
        "success": True,  # the goal after the last action: rendering checks it
        # Where steps were recorded after the goal (--after-goal): the steps to it.
        **({"goal_step": int(record.goal_step)} if record.goal_step else {}),
        # Where its fixtures stood (a replay places them so before restoring its states), and
        # what its source tells of it (an import: the file, its checks).
        **({"fixtures": record.fixtures} if record.fixtures is not None else {}),
        **record.details,
    }


def _final_state(env: Any, record: EpisodeRecord) -> np.ndarray:
    """The state after an episode's last action: searched episodes keep it; an episode taken
    from a dataset (which stores each frame's state before its action) steps it again."""
    if record.final_state is not None:
        return record.final_state
    states, actions = record.trajectory()
    env.set_state(states[-1])
    env.advance(actions[-1])
    return np.asarray(env.get_state())


def env_settings(request: GenerateRequest, task: Any) -> tuple[int, tuple[str, ...], str, float, int | None]:
    """:func:`expert_env`'s settings for ``task`` of ``request`` (the search's and the render's)."""
    return (
        request.image_size,
        tuple(request.cameras),
        request.render_quality,
        request.arm_noise,
        request.length_bound(task),
    )


def make_episodes(ctx: WorkerContext, job: EpisodeJob) -> list[EpisodeDone]:
    """Search and record the job's episodes (a :mod:`~libero_data.runtime.jobs` job).

    An episode's shard is completed (videos flushed, parquet, MCAP, moved into place) in a
    background thread while the next episode is searched and rendered: the search runs on one
    core and leaves the other free. An episode is reported only once its shard is on disk.
    """
    from libero_data.record.shard import render_shard
    from libero_data.runtime.memory import release_free_memory
    from libero_data.tasks import get_suite

    request = job.request
    task = get_suite(request.suite).task(job.task_index)
    source = source_of(request)
    for key, data in job.records:
        if not (path := ctx.root / search_path(key)).is_file():
            write_bytes(path, data)
    done: list[EpisodeDone] = []
    writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="shard-writer")
    pending: tuple[Slot, EpisodeRecord, Future[Path] | None] | None = None

    def settle() -> None:
        """Wait for the previous episode's shard, then report that episode."""
        nonlocal pending
        if pending is None:
            return
        slot, record, finishing = pending
        pending = None
        if finishing is not None:
            finishing.result()
            release_free_memory()  # what the episode's encoders and buffers freed
            ctx.ship(shard_path(slot.key))
        ctx.ship(search_path(slot.key))  # last: its presence marks the slot as done
        event = done_event(slot, record)
        done.append(event)
        ctx.report(event)

    try:
        for k in job.ks:
            slot = Slot(job.position, job.task_index, k)
            search, shard = ctx.root / search_path(slot.key), ctx.root / shard_path(slot.key)
            if search.is_file():
                record = EpisodeRecord.load(search)
            else:
                made = source.search(ctx.cache, task, request, slot)
                if made is None:
                    raise DatasetError(
                        f"episode {slot.key}: its record (written from the source before rendering) is missing; "
                        "run the command again"
                    )
                record = made
                record.save(search)
            finishing = None
            if record.success and not shard.is_dir():
                env, _expert = expert_env(ctx.cache, task, *env_settings(request, task))
                source.set_scene(env, record)
                states, actions = record.trajectory()
                finish = render_shard(
                    shard,
                    env=env,
                    states=states,
                    actions=actions,
                    final_state=_final_state(env, record),
                    task=task.name,
                    instruction=task.language,
                    layout=request.layout,
                    sim_state_width=job.sim_state_width,
                    info=episode_info(task, slot, record, env.gl_info()),
                )
                finishing = writer.submit(finish)
            settle()
            pending = (slot, record, finishing)
        settle()
    finally:
        writer.shutdown(wait=True)  # an interrupted job still completes the shard in hand
    return done
