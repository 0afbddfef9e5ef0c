"""A libero-bench run folder: its final checkpoint, in the evaluation view of one of its tasks
(PackNet's masks), prompts embedded with the run's language encoder."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.rollouts.actors import BatchActor
from libero_bench.rollouts.policy_kinds import (
    RUN,
    PolicyKind,
    PolicySource,
    SourceOptions,
    TrainingStarts,
    is_server,
    register_kind,
)


def is_run(policy: str) -> bool:
    """Whether ``policy`` is a libero-bench run folder."""
    from libero_bench.runs.folder import RunFolder

    return not is_server(policy) and RunFolder(Path(policy)).is_run()


def run_source(policy: str, options: SourceOptions) -> PolicySource:
    """The source of the run folder ``policy`` (its checkpoint is loaded once now: a run that does
    not fit is one sentence before any rollout)."""
    from libero_bench.rollouts.actors import PolicyActor
    from libero_bench.runs.saved_policy import load_run_policy

    folder = Path(policy).resolve()
    checked = load_run_policy(folder)
    config = checked.config
    size = int(config["policy_config"]["image_size"])
    tasks = tuple(t["name"] for t in config["tasks"][: checked.last + 1])

    def open_actor(device: str, view: int | None) -> BatchActor:
        return PolicyActor(load_run_policy(folder, device, view).policy)

    return PolicySource(
        str(folder),
        RUN,
        checked.name,
        size,
        {"run": str(folder), "image_size": size, "language_encoder": config["preset"]["language_encoder"]},
        open_actor,
        reads=PolicyActor.reads,
        embed=lambda prompts: np.asarray(checked.embed(list(prompts)), dtype=np.float32),
        tasks=tasks,
        starts=lambda: run_training_starts(folder, config),
    )


def run_training_starts(folder: Path, config: dict[str, Any]) -> TrainingStarts:
    """Where a run's demonstrations started, per task (its dataset's and those of any dataset
    mixed in): the run's own record, or its datasets' for a run that predates it."""
    from libero_bench.runs.training_data import resolve, run_training_data

    data = run_training_data(folder, config)
    found = {name: (set(stored), set(seeds)) for name, (stored, seeds) in data.starts.items()}
    # the dataset as a path, like the other kinds' (the record names it from the run folder)
    return str(resolve(folder, data.datasets[0])), found


register_kind(PolicyKind(RUN, 10, is_run, run_source))
