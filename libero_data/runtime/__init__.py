"""The machinery every long job shares: its work folder, atomic files and journals, one job
runner (this process, worker processes or Ray) with per-worker caches, memory hygiene for
long-lived workers, and the versions every artifact records.

Nothing here knows about tasks, datasets or policies; ``pipeline``, ``experts.report``,
``procedural.suite`` and ``libero_bench.evaluation.evaluator`` compose it.
"""

from libero_data.runtime.folder import DATASET_WORK, WorkFolder, changed_keys
from libero_data.runtime.jobs import JobPlacement, JobRunner, WorkerCache, WorkerContext
from libero_data.runtime.versions import versions

__all__ = [
    "DATASET_WORK",
    "JobPlacement",
    "JobRunner",
    "WorkFolder",
    "WorkerCache",
    "WorkerContext",
    "changed_keys",
    "versions",
]
