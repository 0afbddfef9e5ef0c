"""One job runner for all parallel work: in this process, in worker processes, or on Ray.

Generation, the expert report, procedural suites and evaluation rollouts all run here. A *job*
is a module-level function ``fn(ctx, payload) -> result`` and a picklable payload; the
:class:`JobRunner` runs many, and yields ``(index, result)`` as each finishes. What a job needs
from where it runs comes through its :class:`WorkerContext`:

- ``ctx.root``: the folder to write under. Locally it is the job's real output folder; on Ray it
  is a scratch folder on the worker's machine, and every path the job passes to ``ctx.ship``
  is sent back and written at the same place under the runner's root (folders atomically, in
  the order shipped), so a cluster needs no storage shared with the driver;
- ``ctx.cache``: a :class:`WorkerCache` that lives as long as the worker process, to keep a
  simulation environment (seconds to build) or a policy from one job to the next;
- ``ctx.report(event)``: progress while the job runs (an episode done, ...); every event of a
  job reaches ``on_event`` in the driver before the job's result is yielded;
- ``ctx.shared``: a file the driver shares with every job of a ``run`` (a policy's weights),
  sent to each Ray worker once.

Worker processes are spawned (a GL context does not survive a fork), die with the driver (even
when it is SIGKILLed), run one OpenMP thread, cap their malloc arenas and hand freed memory back
after every job (:mod:`libero_data.runtime.memory`). They are kept for the runner's lifetime, so
imports and caches survive between calls of :meth:`JobRunner.run`. A result never depends on
which worker ran a job or in which order jobs finished.
"""

from __future__ import annotations

import hashlib
import logging
import os
import queue as queue_module
import shutil
import tempfile
from collections.abc import Callable, Hashable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from libero_data.errors import ExecutorError
from libero_data.runtime.files import pack, unpack

if TYPE_CHECKING:
    from concurrent.futures import Future, ProcessPoolExecutor

log = logging.getLogger(__name__)

P = TypeVar("P")
R = TypeVar("R")
V = TypeVar("V")
JobFn = Callable[["WorkerContext", Any], Any]

EXECUTORS = ("local", "ray")


@dataclass(frozen=True)
class JobPlacement:
    """Where jobs run: ``local`` in ``workers`` processes, or ``ray`` with ``workers`` CPUs of a
    Ray instance started here (or of the cluster at ``ray_address``).

    ``--workers N`` means the same in every command: N processes do the work, and 1 is this
    process (no worker is started); from 2 on, N worker processes are started.
    """

    kind: str = "local"
    workers: int = 1
    ray_address: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in EXECUTORS:
            raise ExecutorError(
                f"unknown executor {self.kind!r}; choose {' or '.join(EXECUTORS)}", field="executor"
            )
        if self.ray_address and self.kind != "ray":
            raise ExecutorError("a Ray address needs the Ray executor", field="ray_address")
        if isinstance(self.workers, bool) or not isinstance(self.workers, int) or self.workers < 1:
            raise ExecutorError(
                f"workers must be 1 (this process) or more (worker processes), got {self.workers}",
                field="workers",
            )

    @property
    def in_process(self) -> bool:
        """Whether the work runs in this process (local, one worker)."""
        return self.kind == "local" and self.workers == 1

    def with_workers(self, workers: int) -> JobPlacement:
        return JobPlacement(self.kind, workers, self.ray_address)

    def describe(self) -> str:
        if self.kind == "ray":
            return f"on Ray ({self.ray_address})" if self.ray_address else f"on Ray ({self.workers} CPUs)"
        return "in this process" if self.in_process else f"with {self.workers} worker processes"


class WorkerCache:
    """What a worker keeps between jobs: one value per slot, rebuilt when the slot's key changes.

    ``get("env", (task, size), build, close)`` returns the environment built for that key, or
    closes the old one and builds the new one. Jobs must not depend on what ran before them in
    a cached value (a simulation environment is reset to a canonical state by every episode).
    """

    def __init__(self) -> None:
        self._slots: dict[str, tuple[Hashable, Any, Callable[[Any], None] | None]] = {}

    def get(
        self, slot: str, key: Hashable, build: Callable[[], V], close: Callable[[V], None] | None = None
    ) -> V:
        entry = self._slots.get(slot)
        if entry is not None and entry[0] == key:
            value: V = entry[1]
            return value
        self.drop(slot)
        value = build()
        self._slots[slot] = (key, value, close)
        return value

    def drop(self, slot: str) -> None:
        entry = self._slots.pop(slot, None)
        if entry is not None and entry[2] is not None:
            entry[2](entry[1])

    def close(self) -> None:
        for slot in list(self._slots):
            self.drop(slot)


class WorkerContext:
    """What a running job gets from the runner (see the module docstring)."""

    def __init__(
        self, root: Path, cache: WorkerCache, shared: Path | None, emit: Callable[[Any], None]
    ) -> None:
        self.root = root
        self.cache = cache
        self.shared = shared
        self._emit = emit
        self.events = 0
        self.shipped: list[str] = []

    def report(self, event: Any) -> None:
        """Send a progress event to the driver's ``on_event``."""
        self.events += 1
        self._emit(event)

    def ship(self, path: str | Path) -> None:
        """Declare a file or folder under ``root`` (relative path) as an output of the job."""
        self.shipped.append(str(path))


# -- inside a worker process -------------------------------------------------------------------------
@dataclass
class _Worker:
    queue: Any
    cache: WorkerCache


_WORKER: _Worker | None = None  # this process's worker state, once it is a worker (never in a driver)
_SHARED_DIR: Path | None = None  # Ray workers: where shared files are kept, by digest


def die_with_parent() -> None:
    """Ask Linux to kill this process when its parent dies (even by SIGKILL)."""
    import ctypes
    import signal
    import sys

    if sys.platform.startswith("linux"):
        pr_set_pdeathsig = 1
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGKILL)


def become_worker(events: Any, setup: Callable[[], None] | None) -> None:
    """Initialise a worker process (a pool's initializer; once per Ray worker process)."""
    from libero_data.runtime.memory import limit_malloc_arenas

    global _WORKER
    limit_malloc_arenas()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("SVT_LOG", "1")  # the AV1 encoder's banner, once per video
    logging.getLogger("libero_data").setLevel(logging.WARNING)
    if setup is not None:
        setup()
    _WORKER = _Worker(queue=events, cache=WorkerCache())


def _init_process(events: Any, setup: Callable[[], None] | None) -> None:
    die_with_parent()
    become_worker(events, setup)


def _process_call(
    fn: JobFn, tag: tuple[int, int], payload: Any, root: str, shared: str | None
) -> tuple[int, Any]:
    """Run one job in a pool worker; returns (events reported, result)."""
    from libero_data.runtime.memory import release_free_memory

    assert _WORKER is not None, "the worker process was not initialised"
    worker = _WORKER
    ctx = WorkerContext(
        Path(root), worker.cache, Path(shared) if shared else None, lambda e: worker.queue.put((tag, e))
    )
    try:
        result = fn(ctx, payload)
    finally:
        release_free_memory()
    return ctx.events, result


def _ray_call(
    fn: JobFn, payload: Any, shared: tuple[str, bytes] | None, setup: Callable[[], None] | None
) -> tuple[list[Any], list[tuple[str, bytes | dict[str, bytes]]], Any]:
    """Run one job on a Ray worker in a scratch folder; returns its events, shipped outputs, result."""
    from libero_data.runtime.memory import release_free_memory

    global _SHARED_DIR
    if _WORKER is None:
        become_worker(None, setup)
    assert _WORKER is not None
    shared_path = None
    if shared is not None:
        digest, data = shared
        if _SHARED_DIR is None:
            _SHARED_DIR = Path(tempfile.mkdtemp(prefix="libero-shared-"))
        shared_path = _SHARED_DIR / digest
        if not shared_path.is_file():
            for old in _SHARED_DIR.iterdir():
                old.unlink()
            shared_path.write_bytes(data)
    events: list[Any] = []
    scratch = Path(tempfile.mkdtemp(prefix="libero-job-"))
    try:
        ctx = WorkerContext(scratch, _WORKER.cache, shared_path, events.append)
        result = fn(ctx, payload)
        shipped = [(rel, pack(scratch / rel)) for rel in ctx.shipped if (scratch / rel).exists()]
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
        release_free_memory()
    return events, shipped, result


# -- in the driver -------------------------------------------------------------------------------------
class JobRunner:
    """Runs jobs with an :class:`JobPlacement`; outputs go under ``root`` (jobs that write nothing
    need none). A context manager: worker
    processes (or the Ray instance started here) live until it closes.

    ``setup`` (a module-level function) runs once in every worker process before its first job,
    e.g. to give torch one thread.
    """

    def __init__(
        self, executor: JobPlacement, root: Path | None = None, *, setup: Callable[[], None] | None = None
    ) -> None:
        self.executor = executor
        self.root = Path.cwd() if root is None else Path(root)
        self.setup = setup
        self._cache = WorkerCache()  # the jobs run in this process
        self._pool: ProcessPoolExecutor | None = None
        self._events: Any = None
        self._ray: Any = None
        self._ray_started = False
        self._runs = 0

    def __enter__(self) -> JobRunner:
        return self

    def __exit__(self, kind: object, error: object, tb: object) -> None:
        self.close(abort=error is not None)

    def close(self, *, abort: bool = False) -> None:
        """Stop the workers; ``abort`` does not wait for the jobs in hand (they are lost)."""
        self._cache.close()
        if self._pool is not None:
            pool, self._pool = self._pool, None
            if abort:
                _terminate_workers(pool)
            pool.shutdown(wait=not abort, cancel_futures=True)
        if self._ray_started:
            self._ray.shutdown()
            self._ray_started = False

    def worker_pids(self) -> list[int]:
        """The process ids of the local worker processes started so far (for measurements)."""
        if self._pool is None:
            return []
        return sorted(getattr(self._pool, "_processes", None) or {})

    def run(
        self,
        fn: JobFn,
        payloads: Sequence[Any],
        *,
        shared: Path | None = None,
        on_event: Callable[[Any], None] | None = None,
    ) -> Iterator[tuple[int, Any]]:
        """Run ``fn`` on every payload; yields ``(index, result)`` in the order jobs finish.

        A job's exception is raised here (with the worker's traceback as its cause) and the
        jobs not started yet are cancelled.
        """
        self._runs += 1
        emit = on_event or (lambda _event: None)
        if not payloads:
            return iter(())
        if self.executor.kind == "ray":
            return self._run_ray(fn, payloads, shared, emit)
        if self.executor.in_process:
            return self._run_here(fn, payloads, shared, emit)
        return self._run_processes(fn, payloads, shared, emit)

    def _run_here(
        self, fn: JobFn, payloads: Sequence[Any], shared: Path | None, emit: Callable[[Any], None]
    ) -> Iterator[tuple[int, Any]]:
        for i, payload in enumerate(payloads):
            yield i, fn(WorkerContext(self.root, self._cache, shared, emit), payload)

    def _run_processes(
        self, fn: JobFn, payloads: Sequence[Any], shared: Path | None, emit: Callable[[Any], None]
    ) -> Iterator[tuple[int, Any]]:
        from concurrent.futures import FIRST_COMPLETED, wait

        pool = self._process_pool()
        run = self._runs
        futures: dict[Future[tuple[int, Any]], int] = {
            pool.submit(
                _process_call, fn, (run, i), payload, str(self.root), str(shared) if shared else None
            ): i
            for i, payload in enumerate(payloads)
        }
        received: dict[int, int] = {}

        def drain(block: bool) -> None:
            while True:
                try:
                    (tag_run, i), event = (
                        self._events.get(timeout=1.0) if block else self._events.get_nowait()
                    )
                except queue_module.Empty:
                    return
                if tag_run == run:
                    received[i] = received.get(i, 0) + 1
                    emit(event)
                if block:
                    return

        pending = set(futures)
        try:
            while pending:
                finished, pending = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
                drain(block=False)
                for future in finished:
                    i = futures[future]
                    sent, result = future.result()
                    while received.get(i, 0) < sent:  # its events are still on their way
                        drain(block=True)
                    yield i, result
        except BaseException:
            for future in pending:
                future.cancel()
            raise

    def _run_ray(
        self, fn: JobFn, payloads: Sequence[Any], shared: Path | None, emit: Callable[[Any], None]
    ) -> Iterator[tuple[int, Any]]:
        ray = self._ray_module()
        remote = ray.remote(num_cpus=1, max_retries=2)(_ray_call)
        blob = None
        if shared is not None:
            data = shared.read_bytes()
            blob = ray.put((hashlib.sha256(data).hexdigest()[:16], data))
        refs = {remote.remote(fn, payload, blob, self.setup): i for i, payload in enumerate(payloads)}
        try:
            while refs:
                done, _ = ray.wait(list(refs), num_returns=1)
                i = refs.pop(done[0])
                events, shipped, result = ray.get(done[0])
                for rel, packed in shipped:
                    unpack(packed, self.root / rel)
                for event in events:
                    emit(event)
                yield i, result
        except BaseException:
            for ref in refs:
                ray.cancel(ref, force=True)
            raise

    def _process_pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            context = mp.get_context("spawn")
            self._events = context.Queue()
            self._pool = ProcessPoolExecutor(
                max_workers=self.executor.workers,
                mp_context=context,
                initializer=_init_process,
                initargs=(self._events, self.setup),
            )
        return self._pool

    def _ray_module(self) -> Any:
        if self._ray is None:
            from libero_data.runtime.ray import start_ray

            self._ray, self._ray_started = start_ray(self.executor.workers, self.executor.ray_address)
        return self._ray


def _terminate_workers(pool: ProcessPoolExecutor) -> None:
    """Kill a pool's workers now (an interrupted run: the jobs in hand are abandoned)."""
    terminate = getattr(pool, "terminate_workers", None)  # Python 3.14+
    if terminate is not None:
        terminate()
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()
