"""``libero-data generate``: demonstrations for a suite, written as a LeRobot dataset.

Work is split into slots (task, episode number) and run as jobs (chunks of one task's
episodes, :mod:`libero_data.pipeline.episodes`) by the runtime's job runner, in this process,
in worker processes or on Ray. Search records and shards are durable files in
``OUT/.libero-data/``, so an interrupted run (even by SIGKILL) loses only the slots in flight
and the same command continues where it stopped. Finished shards are published into ``OUT``
as complete snapshots (see :mod:`publish`), in slot order, so episode indices never change and
what is on disk is always a loadable dataset.

The content depends only on the request (suite, tasks, episodes, image size, seed), never on
the number of workers, the executor, or interruptions.
"""

from __future__ import annotations

import hashlib
import json
import logging
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from libero_data.errors import FolderError, SettingsChanged
from libero_data.pipeline.episodes import (
    EpisodeDone,
    EpisodeJob,
    done_event,
    make_episodes,
    search_path,
    shard_path,
)
from libero_data.pipeline.request import GenerateRequest, sim_state_width, slots_of
from libero_data.pipeline.resolve import resolve_request
from libero_data.pipeline.sources import EpisodeRecord
from libero_data.runtime.files import write_json
from libero_data.runtime.folder import DATASET_WORK, WorkFolder, changed_keys
from libero_data.runtime.jobs import JobPlacement, JobRunner

__all__ = ["GenerateRequest", "Progress", "PublishClock", "generate", "resolve_request"]

log = logging.getLogger(__name__)

PUBLISH_SHARE = 0.05  # most of the run's wall time that publishing snapshots may take
#: What an interrupted run may leave half-written in the work folder.
LEFTOVERS = ("shards/*.tmp-*", "search/*.tmp.npz", "snapshots/*")


class PublishClock:
    """When the growing dataset is next published.

    A snapshot rebuilds the whole dataset from its shards, so it takes longer with every
    episode, and a fixed interval would spend a growing share of a long run publishing, in the
    end most of it. The wait after a publish is therefore at least ``every``
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


@dataclass
class Progress:
    """Counters reported to a callback while generating."""

    total: int
    done: int = 0
    failed: int = 0
    attempts: int = 0
    published: int = 0
    events: list[str] = field(default_factory=list)


class _Run:
    """One generate call: the slots' status, progress and publishing."""

    def __init__(
        self,
        request: GenerateRequest,
        out: Path,
        width: int,
        *,
        command: str,
        publish_every: float,
        on_progress: Callable[[Progress], None] | None,
    ) -> None:
        self.request, self.out, self.width, self.command = request, out, width, command
        self.work = out / DATASET_WORK
        self.slots = slots_of(request)
        self.status: dict[str, EpisodeDone] = {}
        self.progress = Progress(total=len(self.slots))
        self.clock = PublishClock(publish_every)
        self.on_progress = on_progress

    def read_status(self) -> None:
        """The slots finished by earlier runs: given up, or searched with their shard on disk."""
        for slot in self.slots:
            search = self.work / search_path(slot.key)
            if search.is_file():
                record = EpisodeRecord.load(search)
                if not record.success or (self.work / shard_path(slot.key)).is_dir():
                    self.note(done_event(slot, record))

    def note(self, done: EpisodeDone) -> None:
        self.status[done.key] = done
        self.progress.done += done.success
        self.progress.failed += not done.success
        self.progress.attempts += done.attempts
        self.tell()

    def tell(self) -> None:
        if self.on_progress:
            self.on_progress(self.progress)

    def jobs(self, workers: int, *, carry_records: bool = False) -> list[EpisodeJob]:
        """Unfinished slots grouped by task; big tasks are split so workers share them.

        ``carry_records``: each job carries the search records already written for its slots
        (by ``import`` or ``rerender``), for workers that do not see this machine's files.
        """
        request = self.request
        chunk = 10 if workers <= 1 else max(2, min(10, request.episodes_per_task // workers or 1))
        jobs = []
        for position, task_index in enumerate(request.tasks):
            slots = [s for s in self.slots if s.position == position and s.key not in self.status]
            for i in range(0, len(slots), chunk):
                part = slots[i : i + chunk]
                written = [(s.key, self.work / search_path(s.key)) for s in part] if carry_records else []
                records = tuple((key, path.read_bytes()) for key, path in written if path.is_file())
                ks = tuple(s.k for s in part)
                jobs.append(EpisodeJob(request, position, task_index, ks, self.width, records))
        return jobs

    @property
    def complete(self) -> bool:
        """Every slot is done (kept or given up) and the dataset says so."""
        return all(s.key in self.status for s in self.slots) and published_count(self.out) == sum(
            1 for done in self.status.values() if done.success
        )

    def maybe_publish(self, force: bool = False) -> None:
        if not force and not self.clock.due():
            return
        started = time.monotonic()
        self.progress.published = self.publish()
        self.clock.published(started, time.monotonic())
        self.tell()

    def publish(self) -> int:
        """Publish the longest finished prefix of slots; returns the number of episodes in it.

        Nothing is rewritten when neither the prefix nor the completeness has changed.
        """
        from libero_data.pipeline.describe import describe_dataset
        from libero_data.pipeline.publish import publish
        from libero_data.pipeline.snapshot import DATASET_META, build_snapshot

        shards: list[Path] = []
        for slot in self.slots:
            if slot.key not in self.status:
                break
            if self.status[slot.key].success:
                shards.append(self.work / shard_path(slot.key))
        complete = all(s.key in self.status for s in self.slots)
        if not shards:
            return 0
        meta_file = self.out / "meta" / DATASET_META
        if meta_file.is_file():
            current = json.loads(meta_file.read_text())
            if published_count(self.out) == len(shards) and bool(current.get("complete")) == complete:
                return len(shards)
        meta, bddl, card, files = describe_dataset(
            self.request, self.slots, self.status, shards, self.width, command=self.command, complete=complete
        )
        # Named by its content, so the same request publishes the same bytes (the card carries the id).
        content = json.dumps([meta, card, [s.name for s in shards]], sort_keys=True).encode()
        snapshot_id = f"{len(shards):06d}-{hashlib.sha256(content).hexdigest()[:16]}"
        snapshot = self.work / "snapshots" / snapshot_id
        snapshot.parent.mkdir(parents=True, exist_ok=True)
        build_snapshot(
            shards,
            snapshot,
            repo_id=self.request.repo_id,
            snapshot_id=snapshot_id,
            dataset_meta=meta,
            bddl=bddl,
            card=card,
            files=files,
        )
        publish(snapshot, self.out, self.work / "publish.json")
        return len(shards)


def published_count(out: Path) -> int:
    """Episodes in the dataset published at ``out`` (0 where there is none yet)."""
    info = out / "meta" / "info.json"
    if not info.is_file():
        return 0
    return int(json.loads(info.read_text()).get("total_episodes", 0))


def _check_out_dir(out: Path, folder: WorkFolder) -> None:
    """A new dataset goes into an empty folder (a generated suite's own files may share it)."""
    from libero_data.tasks import SUITE_FILES

    if (folder.root / "request.json").is_file():
        return
    if out.exists() and any(p.name not in (DATASET_WORK, *SUITE_FILES) for p in out.iterdir()):
        raise FolderError(
            f"{out} is not empty and is not a libero-data dataset; choose an empty or new folder"
        )


def finished(out: Path, request: GenerateRequest) -> Progress | None:
    """The finished dataset at ``out`` made by ``request`` (its work files removed), if there is
    one; :class:`SettingsChanged` where the finished dataset was made by another request."""
    meta_path = out / "meta" / "libero.json"
    if (out / DATASET_WORK).exists() or not meta_path.is_file():
        return None
    meta = json.loads(meta_path.read_text())
    if not meta.get("complete"):
        return None
    changed = changed_keys(
        GenerateRequest.upgrade(meta["request"]), GenerateRequest.upgrade(request.to_dict())
    )
    if changed:
        raise SettingsChanged(
            f"{out} holds a finished dataset made with different settings ({', '.join(changed)}); "
            "choose another output folder",
            changed=changed,
        )
    tasks = meta.get("tasks", [])
    episodes = sum(int(t["episodes"]) for t in tasks)
    slots = len(request.tasks) * request.episodes_per_task
    attempts = sum(int(t["attempts"]) for t in tasks)
    return Progress(
        total=slots, done=episodes, failed=slots - episodes, attempts=attempts, published=episodes
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
    keep_work: bool = False,
) -> Progress:
    """Generate (or continue generating) the requested dataset into ``out``.

    ``executor="local"`` runs ``workers`` processes on this machine; ``"ray"`` runs the jobs on
    Ray (on the cluster at ``ray_address``, or on a Ray instance started here with ``workers``
    CPUs). Either way the driver writes every file, so a cluster needs no shared storage, and
    the same request gives the same dataset. Once every episode is done the work files
    (``.libero-data/``) are removed, so the folder holds the dataset only, ready to upload;
    ``keep_work`` keeps them. Generating a finished dataset again does nothing.
    """
    from libero_data.pipeline.publish import recover, unstamp

    runner_executor = JobPlacement(executor, workers, ray_address)
    out = Path(out).resolve()
    done = check_output(request, out)
    if done is not None:
        unstamp(out)
        if on_progress:
            on_progress(done)
        return done
    folder = WorkFolder(out / DATASET_WORK, "dataset")
    with folder.locked(owner=out):
        folder.claim(request.to_dict(), name="request.json", owner=out, upgrade=GenerateRequest.upgrade)
        recover(out, folder.path("publish.json"))
        folder.clean(*LEFTOVERS)
        width_file = folder.path("sim_state_width.json")
        if width_file.is_file():
            width = int(json.loads(width_file.read_text()))
        else:
            width = sim_state_width(request)
            write_json(width_file, width, indent=None, newline=False)
        run = _Run(request, out, width, command=command, publish_every=publish_every, on_progress=on_progress)
        run.read_status()
        run.tell()

        def landed(event: EpisodeDone) -> None:
            run.note(event)
            run.maybe_publish()

        with JobRunner(runner_executor, folder.root) as runner:
            jobs = run.jobs(workers, carry_records=runner_executor.kind == "ray")
            for _ in runner.run(make_episodes, jobs, on_event=landed):
                run.maybe_publish()
        run.maybe_publish(force=True)
    if run.complete and not keep_work:
        unstamp(out)
        shutil.rmtree(folder.root, ignore_errors=True)
    return run.progress


def check_output(request: GenerateRequest, out: Path) -> Progress | None:
    """Everything that would refuse ``generate`` into ``out``, checked without writing: another
    dataset or other settings there, or another process writing it. Returns the finished
    dataset's progress where ``out`` already holds this request's dataset."""
    out = Path(out).resolve()
    done = finished(out, request)
    if done is not None:
        return done
    folder = WorkFolder(out / DATASET_WORK, "dataset")
    _check_out_dir(out, folder)
    folder.check_free(owner=out)
    folder.claim(
        request.to_dict(), name="request.json", owner=out, upgrade=GenerateRequest.upgrade, record=False
    )
    return None
