"""The driver's loop: jobs onto environment slots, one batched policy call per turn.

:class:`EnvironmentSlots` holds ``batch_size`` environment slots spread over the workers of an
:class:`~libero_data.runtime.actors.ActorPool` (worker processes, Ray actors, or a thread of this
process); :meth:`EnvironmentSlots.run` rolls a :class:`~libero_bench.rollouts.actors.BatchActor`
out on a list of jobs. The slots form one group, or two halves when every worker holds two slots
or more. Each turn the actor is asked once, for the running slots of a group; then the workers
step those slots (a queued chunk's actions in one go) and start the next jobs on its free ones.
With two halves, one half's steps run while the policy answers the other. An episode that ends
frees its slot for the next job while the others go on.

What a rollout does depends on its job only: its start (task, kind of start, rollout index) is
fixed by the job, whatever the batch size, the number of workers or the order in which episodes
end. What may still differ with the batch size is the last bits of the policy's outputs (a
batched matrix product may sum in another order), which a contact-rich episode can amplify.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_bench.rollouts.actors import Start
from libero_data.runtime.jobs import JobPlacement

if TYPE_CHECKING:
    from libero_bench.rollouts.actors import BatchActor
    from libero_bench.rollouts.jobs import RolloutJob, RolloutResult
    from libero_data.runtime.actors import ActorPool

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RolloutResources:
    """How an evaluation runs: where the environments step (an
    :class:`~libero_data.runtime.jobs.JobPlacement`: this process, ``workers`` worker processes, or
    Ray actors), ``batch_size`` environments at once (default: two per worker, in two halves that
    take turns: :meth:`EnvironmentSlots.run`), the policy on
    ``device`` (default: cuda where available, then mps, else cpu)."""

    executor: JobPlacement = field(default_factory=JobPlacement)
    batch_size: int | None = None
    device: str | None = None

    def __post_init__(self) -> None:
        from libero_data.errors import InputError

        if self.batch_size is not None and self.batch_size < 1:
            raise InputError(f"the batch size must be at least 1, got {self.batch_size}", field="batch_size")
        if self.device is not None and self.device.split(":")[0] not in ("cpu", "cuda", "mps"):
            raise InputError(f"unknown device {self.device!r}; choose cpu, cuda or mps", field="device")

    @property
    def environments(self) -> int:
        """How many environments run at once (the policy's batch)."""
        return self.batch_size or 2 * self.executor.workers

    def policy_device(self) -> str:
        from libero_bench.rollouts.actors import default_device

        return self.device or default_device()

    def open(self, root: Path) -> EnvironmentSlots:
        """The environments, under ``root`` (a context manager)."""
        return EnvironmentSlots(self.executor, root, self.environments)


class EnvironmentSlots:
    """``batch_size`` environment slots in the workers of ``executor`` (a context manager; the
    workers and their environments live until it closes, across calls of :meth:`run`)."""

    def __init__(self, executor: JobPlacement, root: Path, batch_size: int) -> None:
        if batch_size < 1:
            raise ValueError(f"batch_size must be at least 1, got {batch_size}")
        # never more local worker processes than environments
        self.executor = (
            executor.with_workers(min(executor.workers, batch_size)) if executor.kind == "local" else executor
        )
        self.root = Path(root)
        self.batch_size = batch_size
        self._pool: ActorPool | None = None
        #: The driver's seconds: starting the workers, in the policy, waiting for the workers.
        self.timing = {"start_s": 0.0, "policy_s": 0.0, "workers_s": 0.0}

    def __enter__(self) -> EnvironmentSlots:
        return self

    def __exit__(self, kind: object, error: object, tb: object) -> None:
        self.close(abort=error is not None)

    def close(self, *, abort: bool = False) -> None:
        if self._pool is not None:
            pool, self._pool = self._pool, None
            pool.close(abort=abort)

    def pool(self) -> ActorPool:
        if self._pool is None:
            from libero_bench.rollouts.episodes import make_host
            from libero_data.runtime.actors import ActorPool

            started = time.perf_counter()
            self._pool = ActorPool(self.executor, self.root, make_host)
            self.timing["start_s"] += time.perf_counter() - started
        return self._pool

    def worker_pids(self) -> list[int]:
        return self._pool.worker_pids() if self._pool is not None else []

    def describe(self) -> dict[str, Any]:
        """How the rollouts ran (recorded in results)."""
        return {
            "batch_size": self.batch_size,
            "executor": self.executor.kind,
            "workers": self.executor.workers,
        }

    def flush(self) -> None:
        """Wait until the workers have written every finished episode (their writer threads)."""
        if self._pool is not None:
            written = self._pool.call({w: ("flush", ()) for w in range(self._pool.size)})
            self.timing["store_s"] = self.timing.get("store_s", 0.0) + sum(written.values())

    def halves(self, workers: int) -> list[list[int]]:
        """The slots in the groups that take turns: two halves when every worker holds two
        slots or more (slot ``s`` in half ``(s // workers) % 2``: each worker has slots in both),
        else one group (all slots step together)."""
        if self.batch_size < 2 * workers:
            return [list(range(self.batch_size))]
        return [[s for s in range(self.batch_size) if (s // workers) % 2 == h] for h in (0, 1)]

    def run(self, actor: BatchActor, jobs: Sequence[RolloutJob]) -> Iterator[tuple[int, RolloutResult]]:
        """Roll ``actor`` out on ``jobs``; yields ``(index, result)`` as episodes end.

        With two halves (:meth:`halves`) the policy acts for one half while the workers step the
        other: a half's call goes out, then the driver collects the other half's answers and asks
        the policy for it, so the workers never wait for the policy unless it is slower than a
        half's steps. Each call carries, per slot, the action the policy gave and the rest of its
        queued chunk (:meth:`BatchActor.ahead`), stepped in one go and drawn only at the end."""
        if not jobs:
            return
        pool = self.pool()
        owner = [slot % pool.size for slot in range(self.batch_size)]
        groups = self.halves(pool.size)
        half_of = {s: h for h, group in enumerate(groups) for s in group}
        todo = deque(range(len(jobs)))
        free = [deque(group) for group in groups]
        running: dict[int, int] = {}  # slot -> job index
        observations: dict[int, Any] = {}  # slots whose next observation awaits the policy
        in_flight: deque[list[int]] = deque()  # the workers of each call out, oldest first
        turn = 0
        try:
            while todo or running:
                group = turn % len(groups)
                turn += 1
                seen = {s: observations.pop(s) for s in groups[group] if s in observations}
                asked = time.perf_counter()
                actions = actor.act(seen) if seen else {}
                self.timing["policy_s"] += time.perf_counter() - asked
                steps = {s: np.stack([a, *actor.ahead(s)]) for s, a in actions.items()}
                starts: dict[int, int] = {}
                while todo and free[group]:
                    slot, index = free[group].popleft(), todo.popleft()
                    job = jobs[index]
                    actor.begin(slot, Start(job.key, job.language, job.task_emb, job.init_index, job.suite))
                    starts[slot] = index
                unseen = frozenset(s for s in steps if not actor.looks(s))
                calls = {}
                for worker in sorted({owner[s] for s in [*starts, *steps]}):
                    mine_starts = {s: jobs[i] for s, i in starts.items() if owner[s] == worker}
                    mine_steps = {s: a for s, a in steps.items() if owner[s] == worker}
                    mine_unseen = frozenset(s for s in unseen if owner[s] == worker)
                    calls[worker] = ("advance", (mine_starts, mine_steps, mine_unseen))
                running.update(starts)
                if calls:
                    pool.submit(calls)
                    in_flight.append(sorted(calls))
                # the oldest call's answers: once both halves are out, or when this half had none
                if not in_flight or (calls and len(in_flight) < len(groups)):
                    continue
                waited = time.perf_counter()
                answers = pool.collect(in_flight.popleft())
                self.timing["workers_s"] += time.perf_counter() - waited
                ended = []
                for replies in answers.values():
                    for slot, (obs, result) in replies.items():
                        if result is None:
                            observations[slot] = obs
                        else:
                            ended.append((slot, result))
                for slot, result in sorted(ended, key=lambda e: e[0]):
                    index = running.pop(slot)
                    actor.end(slot, result.success)
                    free[half_of[slot]].append(slot)
                    if not todo and not running:  # the last one: every episode written before it is given
                        self.flush()
                    yield index, result
        except GeneratorExit:
            # the caller stopped early: the workers forget the episodes in hand, write the finished
            pool.drain()
            pool.call({w: ("abandon", ()) for w in sorted(set(owner))})
            raise
        except Exception:
            with contextlib.suppress(Exception):  # the finished episodes are written if the workers can
                pool.drain()
                self.flush()
            raise
