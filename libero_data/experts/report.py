"""Measuring the expert: success rate per task over its stored init states.

Each task is a job of the runtime's job runner (in this process or in worker processes, each
building its own simulator). Finished tasks are journalled (:class:`ReportJournal`) so a report
resumes where it stopped; the tables are written by :mod:`libero_data.cards.expert_table`.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.errors import FolderError, MissingFileError, SettingsChanged
from libero_data.experts.expert import ExpertConfig
from libero_data.runtime.files import Journal
from libero_data.runtime.folder import changed_keys
from libero_data.runtime.jobs import JobPlacement, JobRunner, WorkerContext
from libero_data.seeding import episode_seeds

__all__ = ["ReportJournal", "TaskResult", "evaluate_task", "failure_reason", "read_report", "run_report"]

log = logging.getLogger(__name__)


@dataclass
class TaskResult:
    suite: str
    index: int
    name: str
    episodes: int
    successes: int
    mean_length: float
    seconds_per_episode: float
    failures: dict[str, int] = field(default_factory=dict)
    #: Steps of each successful episode, and where they went summed over them (skills, failed
    #: attempts, the wait for the goal: ``Episode.phases``). Empty in reports made before.
    lengths: list[int] = field(default_factory=list)
    phases: dict[str, int] = field(default_factory=dict)

    @property
    def rate(self) -> float:
        return self.successes / self.episodes if self.episodes else 0.0


def evaluate_task(
    task_ref: str,
    inits: int,
    *,
    seed: int = 0,
    config: ExpertConfig | None = None,
    on_episode: Callable[[bool], None] | None = None,
) -> TaskResult:
    """Run the expert from the first ``inits`` stored init states of one task."""
    from libero_data.experts.expert import Expert
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    task = get_task(task_ref)
    states = task.init_states()[:inits]
    failures: Counter[str] = Counter()
    lengths: list[int] = []
    kept: list[int] = []  # the successful episodes' lengths: what a dataset keeps
    phases: Counter[str] = Counter()
    successes = 0
    start = time.perf_counter()
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        expert = Expert(env, config)
        for i, state in enumerate(states):
            reset_seed, expert_seed = episode_seeds(seed, task.id, i)
            try:
                episode = expert.run(state, reset_seed=reset_seed, seed=expert_seed)
            except Exception as exc:  # a bug in one episode must not end the whole report
                log.exception("expert crashed on %s init %d", task.id, i)
                failures[f"error: {type(exc).__name__}"] += 1
                if on_episode is not None:
                    on_episode(False)
                continue
            lengths.append(episode.length)
            if episode.success:
                successes += 1
                kept.append(episode.length)
                phases.update(episode.phases)
            else:
                failures[failure_reason(episode.failure)] += 1
            if on_episode is not None:
                on_episode(episode.success)
    elapsed = time.perf_counter() - start
    return TaskResult(
        suite=task.suite,
        index=task.index,
        name=task.name,
        episodes=len(states),
        successes=successes,
        mean_length=float(np.mean(lengths)) if lengths else 0.0,
        seconds_per_episode=elapsed / max(len(states), 1),
        failures=dict(failures.most_common()),
        lengths=kept,
        phases=dict(phases.most_common()),
    )


class ReportJournal:
    """``expert_report.jsonl``: a header (the settings, and the machine that measured them), then
    one line per finished task.

    Each line is written and synced as its task finishes, so an interrupted report keeps
    every finished task; running the same command again measures only the rest.
    """

    NAME = "expert_report.jsonl"

    def __init__(
        self, out_dir: str | Path, settings: dict[str, object], *, fresh: bool = False, machine: str = ""
    ) -> None:
        self.journal = Journal(Path(out_dir) / self.NAME)
        self.path = self.journal.path
        self.settings = settings
        #: The first line: ``settings`` and, where given, ``machine`` (how the tables describe the
        #: numeric path the rows were measured on).
        self.header: dict[str, Any] = {"settings": settings, **({"machine": machine} if machine else {})}
        self.done: dict[str, TaskResult] = {}
        if self.journal.exists() and not fresh:
            self._load()
        else:
            self.journal.start(self.header)

    def _load(self) -> None:
        self.header, self.done = read_report(self.path)
        changed = changed_keys(self.header["settings"], self.settings)
        if changed:
            raise SettingsChanged(
                f"{self.path} was measured with different settings ({', '.join(changed)}); "
                "start a fresh report or use another output folder",
                changed=changed,
            )

    def add(self, ref: str, result: TaskResult) -> None:
        self.journal.append({"ref": ref, **asdict(result)})
        self.done[ref] = result


def read_report(path: str | Path) -> tuple[dict[str, Any], dict[str, TaskResult]]:
    """An expert report's journal: its header and its measured tasks by reference, in order."""
    journal = Journal(Path(path))
    if not journal.exists():
        raise MissingFileError(f"expert report journal {path} does not exist")
    lines = journal.read()
    header = lines[0] if lines and isinstance(lines[0], dict) else None
    if header is None or not isinstance(header.get("settings"), dict):
        raise FolderError(f"{path} is not an expert report journal; start over with a fresh report")
    done: dict[str, TaskResult] = {}
    for number, row in enumerate(lines[1:], 2):
        try:
            ref = row.pop("ref")
            done[ref] = TaskResult(**row)
        except (AttributeError, KeyError, TypeError):
            raise FolderError(
                f"{path}, entry {number} is not a measured task; start over with a fresh report"
            ) from None
    return header, done


def failure_reason(text: str | None) -> str:
    """A failure message as the table shows it (kept whole: within one task the names in it
    are the same from episode to episode, so equal failures still group)."""
    if not text:
        return "unknown"
    return " ".join(text.split())[:100]


@dataclass(frozen=True)
class _TaskJob:
    ref: str
    inits: int
    seed: int
    config: ExpertConfig
    code: str  # the expert code the report was started with


def _measure(ctx: WorkerContext, job: _TaskJob) -> TaskResult:
    """One task of the report (a job). A worker runs the code it imported when it started; a
    task measured with code edited since the report began must not join its rows."""
    from libero_data.provenance import expert_code

    now = expert_code()
    if now != job.code:
        raise SettingsChanged(
            f"the expert's code changed while the report ran (was {job.code}, now {now}); "
            f"{job.ref} was not measured. Start a fresh report to go on with the new code",
            changed=["expert"],
        )
    return evaluate_task(job.ref, job.inits, seed=job.seed, config=job.config)


def run_report(
    task_refs: Iterable[str],
    inits: int,
    *,
    seed: int = 0,
    workers: int = 1,
    config: ExpertConfig | None = None,
    on_task: Callable[[str, TaskResult], None] | None = None,
    fingerprint: str | None = None,
) -> list[TaskResult]:
    """Evaluate many tasks, in ``workers`` processes; results in the order given.

    ``on_task`` is called as each task finishes (in finishing order). Every task first
    checks that the expert's code still has ``fingerprint`` (default: as it is now).
    """
    from libero_data.provenance import expert_code

    refs = list(task_refs)
    config = config or ExpertConfig()
    jobs = [_TaskJob(ref, inits, seed, config, fingerprint or expert_code()) for ref in refs]
    results: dict[str, TaskResult] = {}
    with JobRunner(JobPlacement("local", workers)) as runner:
        for i, result in runner.run(_measure, jobs):
            results[refs[i]] = result
            if on_task:
                on_task(refs[i], result)
    return [results[r] for r in refs]
