"""Long-lived workers driven step by step: each holds one object and runs the driver's method calls.

The job runner (:mod:`libero_data.runtime.jobs`) suits work that a worker does from start to end
alone. Evaluating a policy that runs once, in the driver, needs the other shape: the driver keeps
the policy, every worker keeps simulation environments, and each control step the driver sends
the actions and gathers the observations. An :class:`ActorPool` is that shape:

- ``ActorPool(executor, root, factory)`` starts ``executor.workers`` workers (worker processes, or
  Ray actors with one CPU each; one local worker: one actor in a thread of this process, so that
  the driver's policy and the actor's steps can overlap), and each builds its
  object with ``factory(ctx)`` (a module-level function; ``ctx`` is a
  :class:`~libero_data.runtime.jobs.WorkerContext` whose cache lives as long as the worker);
- ``pool.call({actor: (method, args)})`` calls those methods on those actors at once and returns
  their results by actor; the actors work in parallel, the call returns when all have answered;
- ``pool.submit(calls)`` sends the calls and returns at once, ``pool.collect(actors)`` waits for
  their answers: the driver works (runs its policy) while the actors do; an actor answers its
  calls in the order they were sent, so several may be in flight; ``pool.drain()`` reads and
  drops every answer still due (after a failure, before the pool is called again);
- files an actor declares with ``ctx.ship`` come back under ``root`` after each call (on Ray, where
  the actor writes into a scratch folder of its machine); locally they are written in place.

Workers are spawned (a GL context does not survive a fork), die with the driver and get the same
setup as the job runner's (one OpenMP thread, malloc arenas capped). An exception in an actor is
raised in the driver with the actor's traceback as its cause; a worker that dies is an
:class:`~libero_data.errors.ExecutorError` naming it.
"""

from __future__ import annotations

import contextlib
import queue
import shutil
import tempfile
import threading
import traceback
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from libero_data.errors import ExecutorError
from libero_data.runtime.files import pack, unpack
from libero_data.runtime.jobs import JobPlacement, WorkerCache, WorkerContext

Factory = Callable[[WorkerContext], Any]
Call = tuple[str, tuple[Any, ...]]


class RemoteTraceback(RuntimeError):
    """The traceback of an exception raised in an actor (the cause of the one re-raised here)."""


def _invoke(target: Any, method: str, args: tuple[Any, ...]) -> tuple[bool, Any]:
    """Call one method; (True, result) or (False, (exception, traceback text))."""
    try:
        return True, getattr(target, method)(*args)
    except Exception as exc:  # sent to the driver, raised there
        return False, (exc, traceback.format_exc())


def _reraise(index: int, payload: tuple[BaseException, str]) -> None:
    exc, text = payload
    raise exc from RemoteTraceback(f"in actor {index}:\n{text}")


def _process_main(conn: Any, factory: Factory, root: str, setup: Callable[[], None] | None) -> None:
    """A worker process: build the object, then run calls until told to stop."""
    from libero_data.runtime.jobs import become_worker, die_with_parent

    die_with_parent()
    become_worker(None, setup)
    cache = WorkerCache()
    ctx = WorkerContext(Path(root), cache, None, lambda _event: None)
    try:
        target = factory(ctx)
        conn.send((True, None))
    except Exception as exc:
        conn.send((False, (exc, traceback.format_exc())))
        return
    try:
        while True:
            message = conn.recv()
            if message is None:
                break
            method, args = message
            reply = _invoke(target, method, args)
            try:
                conn.send(reply)
            except Exception as exc:  # an unpicklable result or exception
                conn.send(
                    (False, (RuntimeError(f"{method} returned something that cannot be sent: {exc}"), ""))
                )
    except (EOFError, KeyboardInterrupt):
        pass
    finally:
        cache.close()
        close = getattr(target, "close", None)
        if callable(close):
            close()


class _ThreadHost:
    """The one actor of a pool in this process: a thread builds the object and runs its calls
    (everything the object holds, a GL context included, stays with that thread)."""

    def __init__(self, factory: Factory, root: Path) -> None:
        self.calls: queue.SimpleQueue[Call | None] = queue.SimpleQueue()
        self.answers: queue.SimpleQueue[tuple[bool, Any]] = queue.SimpleQueue()
        self.thread = threading.Thread(target=self._main, args=(factory, root), name="actor-0", daemon=True)
        self.thread.start()

    def _main(self, factory: Factory, root: Path) -> None:
        cache = WorkerCache()
        try:
            target = factory(WorkerContext(root, cache, None, lambda _event: None))
        except Exception as exc:
            cache.close()
            self.answers.put((False, (exc, traceback.format_exc())))
            return
        self.answers.put((True, None))
        try:
            while (message := self.calls.get()) is not None:
                self.answers.put(_invoke(target, *message))
        finally:
            cache.close()
            close = getattr(target, "close", None)
            if callable(close):
                close()

    def receive(self) -> tuple[bool, Any]:
        while True:
            try:
                return self.answers.get(timeout=1.0)
            except queue.Empty:
                if not self.thread.is_alive():
                    raise ExecutorError(
                        "the simulation thread of this process stopped", field="workers"
                    ) from None

    def stop(self, *, abort: bool) -> None:
        self.calls.put(None)
        self.thread.join(timeout=0 if abort else 60)


class _RayHost:
    """The object a Ray actor keeps; files it ships come back with every call's result."""

    def __init__(self, factory: Factory, setup: Callable[[], None] | None) -> None:
        from libero_data.runtime.jobs import become_worker

        become_worker(None, setup)
        self.scratch = Path(tempfile.mkdtemp(prefix="libero-actor-"))
        self.ctx = WorkerContext(self.scratch, WorkerCache(), None, lambda _event: None)
        self.target = factory(self.ctx)

    def call(self, method: str, args: tuple[Any, ...]) -> tuple[bool, Any, list[tuple[str, Any]]]:
        ok, result = _invoke(self.target, method, args)
        shipped = [
            (rel, pack(self.scratch / rel)) for rel in self.ctx.shipped if (self.scratch / rel).exists()
        ]
        for rel in self.ctx.shipped:
            path = self.scratch / rel
            shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)
        self.ctx.shipped.clear()
        return ok, result, shipped


class ActorPool:
    """Workers that each hold one object built by ``factory`` (see the module docstring)."""

    def __init__(
        self,
        executor: JobPlacement,
        root: Path,
        factory: Factory,
        *,
        setup: Callable[[], None] | None = None,
    ) -> None:
        self.executor = executor
        self.root = Path(root)
        self._here: _ThreadHost | None = None
        self._processes: list[tuple[Any, Any]] = []
        self._ray_actors: list[Any] = []
        self._ray: Any = None
        self._ray_started = False
        #: Answers not collected yet, per actor, oldest first: a Ray reference, or None where the
        #: answer waits in the actor's pipe or queue (a worker process, this process's thread).
        self._due: dict[int, deque[Any]] = {}
        if executor.kind == "ray":
            self._start_ray(factory, setup)
        elif executor.in_process:
            self._here = _ThreadHost(factory, self.root)
            ok, payload = self._here.receive()
            if not ok:
                self.close(abort=True)
                _reraise(0, payload)
        else:
            self._start_processes(factory, setup)

    @property
    def size(self) -> int:
        """How many actors there are."""
        if self._here is not None:
            return 1
        return len(self._processes) or len(self._ray_actors)

    def _start_processes(self, factory: Factory, setup: Callable[[], None] | None) -> None:
        import multiprocessing as mp

        context = mp.get_context("spawn")
        for _ in range(self.executor.workers):
            parent, child = context.Pipe()
            process = context.Process(
                target=_process_main, args=(child, factory, str(self.root), setup), daemon=True
            )
            process.start()
            child.close()
            self._processes.append((process, parent))
        for i in range(len(self._processes)):
            ok, payload = self._receive(i)
            if not ok:
                self.close(abort=True)
                _reraise(i, payload)

    def _start_ray(self, factory: Factory, setup: Callable[[], None] | None) -> None:
        from libero_data.runtime.ray import start_ray

        self._ray, self._ray_started = start_ray(self.executor.workers, self.executor.ray_address)
        host = self._ray.remote(num_cpus=1)(_RayHost)
        self._ray_actors = [host.remote(factory, setup) for _ in range(max(self.executor.workers, 1))]

    def _receive(self, i: int) -> tuple[bool, Any]:
        process, conn = self._processes[i]
        try:
            reply: tuple[bool, Any] = conn.recv()
        except (EOFError, OSError) as exc:
            process.join(timeout=5)
            raise ExecutorError(
                f"simulation worker {i} (process {process.pid}) died with exit code {process.exitcode}",
                field="workers",
            ) from exc
        return reply

    def call(self, calls: Mapping[int, Call]) -> dict[int, Any]:
        """Call ``{actor: (method, args)}`` at once; the results by actor."""
        self.submit(calls)
        return self.collect(list(calls))

    def submit(self, calls: Mapping[int, Call]) -> None:
        """Send ``{actor: (method, args)}`` without waiting; :meth:`collect` gets the answers."""
        if self._here is not None:  # this process: the actor's thread runs it
            for i, message in calls.items():
                self._here.calls.put(message)
                self._due.setdefault(i, deque()).append(None)
            return
        if self._ray_actors:
            for i, (method, args) in calls.items():
                self._due.setdefault(i, deque()).append(self._ray_actors[i].call.remote(method, args))
            return
        for i, message in calls.items():
            try:
                self._processes[i][1].send(message)
            except (BrokenPipeError, OSError):
                self._receive(i)  # raises the worker's death
            self._due.setdefault(i, deque()).append(None)

    def collect(self, actors: Sequence[int]) -> dict[int, Any]:
        """The oldest answer due from each of ``actors`` (raising the first actor's failure once
        all have answered)."""
        replies = {i: self._next(i) for i in actors}
        for i, (ok, payload) in replies.items():
            if not ok:
                _reraise(i, payload)
        return {i: payload for i, (_ok, payload) in replies.items()}

    def drain(self) -> None:
        """Read and drop every answer still due (their failures too)."""
        for i in list(self._due):
            while self._due[i]:
                with contextlib.suppress(Exception):
                    self._next(i)

    def _next(self, i: int) -> tuple[bool, Any]:
        due = self._due.get(i)
        if not due:
            raise RuntimeError(f"actor {i} has no answer due")
        entry = due.popleft()
        if self._here is not None:
            return self._here.receive()
        if self._ray_actors:
            ok, result, shipped = self._ray.get(entry)
            for rel, packed in shipped:
                unpack(packed, self.root / rel)
            return ok, result
        return self._receive(i)

    def worker_pids(self) -> list[int]:
        """The process ids of the local worker processes (for measurements)."""
        return [int(p.pid) for p, _ in self._processes]

    def __enter__(self) -> ActorPool:
        return self

    def __exit__(self, kind: object, error: object, tb: object) -> None:
        self.close(abort=error is not None)

    def close(self, *, abort: bool = False) -> None:
        """Stop the workers (``abort``: without waiting for them to tidy up)."""
        if self._here is not None:
            here, self._here = self._here, None
            here.stop(abort=abort)
        processes, self._processes = self._processes, []
        if not abort:
            for _process, conn in processes:
                with contextlib.suppress(BrokenPipeError, OSError):
                    conn.send(None)
        for process, conn in processes:
            process.join(timeout=0 if abort else 30)
            if process.is_alive():
                process.terminate()
                process.join(timeout=5)
            conn.close()
        for actor in self._ray_actors:
            self._ray.kill(actor)
        self._ray_actors = []
        if self._ray_started:
            self._ray.shutdown()
            self._ray_started = False
