"""The rollout session: a folder of evaluation rollouts that runs, resumes, joins and cleans up,
whatever asked for the rollouts (``libero-bench eval``, a robustness sweep, a run's rounds).

::

    FOLDER/
      results.json       every finished rollout's record, the sessions that ran them, versions
      rollouts/          the rollouts joined into one LeRobot dataset (once all are in)
      rrd/<key>.rrd      a Rerun recording per rollout
      .work/shards/<key> a rollout as written by its worker (removed once joined, unless kept)

A rollout is finished once its record is in ``results.json`` and its shard is on disk (or the
folder is joined): an interrupted session runs only the others again. The caller gives the jobs
in groups, each with the actor that acts for it (a run's per-task evaluation view, or one
policy for all), and a record per rollout (:func:`rollout_record` plus what it adds).
"""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from libero_bench.runs.folder import RunFolder

if TYPE_CHECKING:
    from libero_bench.rollouts.actors import BatchActor
    from libero_bench.rollouts.jobs import RolloutJob, RolloutResult
    from libero_bench.rollouts.loop import EnvironmentSlots, RolloutResources

#: A group of rollouts and what opens the actor that acts for them (on the device given).
Group = tuple[Callable[[str], "BatchActor"], Sequence["RolloutJob"]]


def rollout_record(job: RolloutJob, result: RolloutResult, **extra: Any) -> dict[str, Any]:
    """What ``results.json`` keeps of a finished rollout (plus ``extra``)."""
    return {
        "key": job.key,
        "task": job.task_name,
        "start": job.start,
        "rollout": int(job.tags["rollout"]),
        "init_index": job.init_index,
        "env_seed": job.env_seed,
        "success": bool(result.success),
        "steps": int(result.steps),
        **extra,
    }


def roll_out(
    environments: EnvironmentSlots,
    actor: BatchActor,
    jobs: Sequence[RolloutJob],
    on_result: Callable[[RolloutResult], None] | None = None,
) -> Iterator[tuple[RolloutJob, RolloutResult]]:
    """Roll ``actor`` out on ``jobs`` in open environments; yields each (job, result) as it ends."""
    for index, result in environments.run(actor, jobs):
        if on_result is not None:
            on_result(result)
        yield jobs[index], result


class RolloutSession:
    """The rollouts of one folder (see the module docstring)."""

    def __init__(self, root: str | Path) -> None:
        self.folder = RunFolder(Path(root))
        self.results = self.folder.results
        self.records: dict[str, dict[str, Any]] = {}
        self.sessions: list[dict[str, Any]] = []
        self.joined = False

    @property
    def root(self) -> Path:
        return self.folder.root

    def load(self) -> RolloutSession:
        """Read what a former session finished (a record whose shard is gone runs again, unless
        the folder is joined), and clear rollout writes an interruption left half done."""
        from libero_data.runtime.files import read_json

        saved = read_json(self.results, required=("rollouts",)) if self.results.is_file() else {}
        self.joined = bool(saved.get("complete")) and (self.folder.rollouts / "meta" / "info.json").is_file()
        self.records = {
            r["key"]: r
            for r in saved.get("rollouts", [])
            if self.joined or (self.folder.shard(r["key"]) / "episode.json").is_file()
        }
        self.sessions = list(saved.get("sessions", []))
        self.clear_partial_writes()
        return self

    def clear_partial_writes(self) -> None:
        """Remove the rollout writes an interruption left half done."""
        from libero_data.runtime.folder import WorkFolder

        WorkFolder(self.folder.work, "rollouts").clean("shards/*.tmp-*")

    def left(self, jobs: Sequence[RolloutJob]) -> list[RolloutJob]:
        """The jobs not finished yet."""
        return [j for j in jobs if j.key not in self.records]

    def run(
        self,
        execution: RolloutResources,
        groups: Sequence[Group],
        record: Callable[[RolloutJob, RolloutResult], dict[str, Any]],
        on_result: Callable[[RolloutResult], None] | None = None,
    ) -> dict[str, Any] | None:
        """Run every group's jobs in one set of environments, each group with its own actor;
        ``results.json`` is written after every rollout. How they ran (batch size, workers, device,
        actor, forward passes) is this session's entry in ``results.json``, returned."""
        groups = [(opener, list(jobs)) for opener, jobs in groups if jobs]
        if not groups:
            return None
        from libero_data.runtime.warm import warm_imports

        warm_imports(
            ("lerobot.datasets.aggregate", "lerobot.datasets.lerobot_dataset")
        )  # what join() imports
        device = execution.policy_device()
        session: dict[str, Any] = {"rollouts": 0, "forwards": 0}
        phases: dict[str, float] = {}
        self.sessions.append(session)
        started = time.perf_counter()
        with execution.open(self.root) as environments:
            session.update(environments.describe())
            for opener, jobs in groups:
                opened = time.perf_counter()
                actor = opener(device)
                phases["open_policy_s"] = phases.get("open_policy_s", 0.0) + time.perf_counter() - opened
                try:
                    session.update(actor.describe())
                    for job, result in roll_out(environments, actor, jobs, on_result):
                        self.records[job.key] = record(job, result)
                        session["rollouts"] += 1
                        for name, seconds in result.phases.items():
                            phases[name] = phases.get(name, 0.0) + seconds
                        self.save(complete=False)
                finally:
                    session["forwards"] += actor.forwards
                    actor.close()
            phases.update(environments.timing)
        phases["session_s"] = time.perf_counter() - started
        # where the time went: the driver's phases, and the workers' summed over rollouts
        session["phases"] = {name: round(seconds, 3) for name, seconds in sorted(phases.items())}
        return session

    def save(self, *, complete: bool, **extra: Any) -> None:
        """Write ``results.json`` (records in key order)."""
        from libero_data.runtime.files import write_json
        from libero_data.runtime.versions import versions

        write_json(
            self.results,
            {
                "rollouts": [self.records[k] for k in sorted(self.records)],
                "complete": complete,
                "sessions": self.sessions,
                "versions": versions(python=True),
                **extra,
            },
        )

    def join(self, meta: Mapping[str, Any], bddl: Mapping[str, str]) -> int:
        """Join every recorded rollout's shard into ``rollouts/`` (one LeRobot dataset)."""
        from libero_bench.rollouts.rollout_dataset import build_rollout_dataset
        from libero_data.errors import RunError
        from libero_data.runtime.files import read_json

        behind = set(read_json(self.folder.left_behind)) if self.folder.left_behind.is_file() else set()
        keys = sorted(self.records)
        here = [k for k in keys if (self.folder.shard(k) / "episode.json").is_file()]
        missing = sorted(set(keys) - set(here) - behind)
        if missing:
            raise RunError(f"{self.root}: rollout {missing[0]} is missing from {self.folder.shards}")
        run_meta = dict(meta)
        if len(here) < len(keys):  # a run carried on from another machine without its shards
            run_meta["rollouts_left_behind"] = sorted(set(keys) - set(here))
        if not here:  # all of them stayed on the machine it came from: nothing to join here
            self.joined = True
            return 0
        started = time.perf_counter()
        count = build_rollout_dataset(
            [self.folder.shard(k) for k in here],
            self.folder.rollouts,
            run_meta=run_meta,
            bddl=dict(bddl),
            work_dir=self.folder.work,
        )
        self.joined = True
        if self.sessions:
            self.sessions[-1].setdefault("phases", {})["join_s"] = round(time.perf_counter() - started, 3)
        return count

    def clean(self, keep_work: bool = False) -> None:
        """Remove the work files (the shards: the joined dataset holds them), unless ``keep_work``."""
        if not keep_work:
            shutil.rmtree(self.folder.work, ignore_errors=True)
