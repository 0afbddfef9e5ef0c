"""The evaluator of libero-bench's own policies (a run's evaluation rounds); every rollout is kept.

What a rollout is (its job, start and result): :mod:`libero_bench.rollouts.jobs`.

The policy acts in the driver process, batched over the environments, which step in workers
(:mod:`libero_bench.rollouts`). Each rollout is written by the worker that ran it, like a
demonstration: a one-episode LeRobot shard with its MCAP log (tagged with task, learned-after
task, epoch, seeds, init index and success) and a Rerun ``.rrd``;
:mod:`libero_bench.evaluation.rollout_dataset` joins the shards into one LeRobot dataset. Rendering
dominates the cost (~50 ms per camera frame on a CPU core, two cameras).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from libero_bench.policies.base import Policy
    from libero_bench.rollouts.jobs import RolloutJob, RolloutResult
    from libero_data.runtime.jobs import Executor


class Evaluator:
    """Rolls libero-bench policies out on environments in ``workers`` processes (0: in this
    process) or on Ray, ``batch_size`` of them at once (default: one per worker); rollouts are
    written under ``root``. The policy acts in this process, on its own device, one batched
    pass per control step (:mod:`libero_bench.rollouts`). A context manager: the workers keep
    their imports and environments between evaluation rounds."""

    def __init__(self, executor: Executor, root: Path, *, batch_size: int | None = None) -> None:
        from libero_bench.rollouts.loop import Execution

        self.root = Path(root)
        self.environments = Execution(executor, batch_size).open(self.root)

    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, kind: object, error: object, tb: object) -> None:
        self.environments.close(abort=error is not None)

    def worker_pids(self) -> list[int]:
        return self.environments.worker_pids()

    def describe(self) -> dict[str, object]:
        """How the rollouts run (batch size, executor, workers), recorded with each round's timing."""
        return self.environments.describe()

    def run(
        self,
        policy: Policy,
        jobs: Sequence[RolloutJob],
        on_result: Callable[[RolloutResult], None] | None = None,
    ) -> list[RolloutResult]:
        """Run ``jobs`` with the policy's current weights; results in the order of ``jobs``."""
        from libero_bench.rollouts.actors import PolicyActor
        from libero_bench.rollouts.session import roll_out

        results = {
            job.key: result
            for job, result in roll_out(self.environments, PolicyActor(policy), jobs, on_result)
        }
        return [results[job.key] for job in jobs]
