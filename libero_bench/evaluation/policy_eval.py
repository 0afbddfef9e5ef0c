"""``libero-bench eval``: a trained LeRobot policy, or a policy served elsewhere over openpi's
websocket protocol, evaluated on tasks, suites, generated suites or robustness variants, with the
benchmark's protocol and outputs. The policy runs once, batched over the environments
(:mod:`libero_bench.rollouts`); ``results.json`` records how each session ran (batch size, workers,
device, forward passes).

Every task is rolled out from LIBERO's stored init states (where it has them) and from held-out
placements (``libero_data.seeding.heldout_starts``, skipping the seeds the policy's training
demonstrations started from when its ``train_config.json`` names a libero-data dataset). Every
rollout is stored like a demonstration (``rollouts/``: one LeRobot dataset, an MCAP log each;
``rrd/``: a Rerun recording each); ``results.json`` lists them, and the report gives every
task's success with n and a 95% Wilson interval. The folder resumes after an interruption.
"""

from __future__ import annotations

import dataclasses
import shutil
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.evaluation.eval_report import chart, eval_markdown, summarize_eval
from libero_bench.rollouts.jobs import EvalTask, RolloutJob, RolloutResult, make_job
from libero_bench.rollouts.loop import Execution
from libero_bench.rollouts.sources import PolicySource, is_server, policy_source
from libero_bench.runs.folder import HELDOUT, STORED, RunFolder
from libero_data.errors import InputError
from libero_data.pipeline.request import state_width
from libero_data.rollout import RolloutSettings
from libero_data.runtime.files import read_json, write_json, write_text
from libero_data.runtime.folder import WorkFolder
from libero_data.tasks.horizons import step_limit

EVAL_FORMAT = "libero-bench-eval/1"


@dataclass(frozen=True)
class EvalRequest(RolloutSettings):
    """What to evaluate: a LeRobot policy folder or a policy server (``ws://HOST:PORT``) on
    tasks, from how many starts of each kind, with the shared rollout settings (``max_steps``,
    ``settle``, ``render_quality``: :class:`~libero_data.rollout.RolloutSettings`). For a server,
    ``image_size`` is the camera size sent (default: the size the server's metadata names, else
    224, openpi's) and ``replan_steps`` the actions executed of each chunk it returns (openpi's
    LIBERO client: 5)."""

    policy: str
    tasks: tuple[str, ...]
    stored: int = 20
    heldout: int = 20
    image_size: int | None = None
    replan_steps: int = 5

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.replan_steps < 1:
            raise InputError("execute at least one action of each chunk", field="replan_steps")
        if self.image_size is not None and self.image_size < 8:
            raise InputError(
                f"the image size must be at least 8 pixels, got {self.image_size}", field="image_size"
            )
        if not self.tasks:
            raise InputError("no tasks to evaluate on", field="tasks")
        for name in ("stored", "heldout"):
            if getattr(self, name) < 0:
                raise InputError(f"the number of {name} starts must not be negative", field=name)
        if self.stored + self.heldout == 0:
            raise InputError("evaluate from at least one start", field="stored")


def resolve_tasks(refs: Sequence[str]) -> list[Any]:
    """Tasks from references: a task (``suite/i``, ``suite/name``, a ``.bddl`` file), a suite
    name or a suite folder (every task of it)."""
    from libero_data.tasks import get_suite, get_task

    out: list[Any] = []
    for ref in refs:
        try:
            out.extend(get_suite(ref).tasks)
        except KeyError:
            out.append(get_task(ref))
    names = [t.name for t in out]
    if len(set(names)) != len(names):
        raise InputError("the task list names a task twice", field="tasks")
    return out


def training_starts(policy: Path) -> tuple[str | None, dict[str, tuple[set[int], set[int]]]]:
    """The dataset the policy was trained on (from ``train_config.json``) and, per task, where its
    demonstrations started (stored init indices, sampler seeds); empty where it is not known."""
    from libero_bench.data.dataset import DemoDataset
    from libero_data.errors import LiberoDataError

    path = policy / "train_config.json"
    if not path.is_file():
        return None, {}
    config = read_json(path)
    root = ((config.get("dataset") if isinstance(config, dict) else None) or {}).get("root")
    if not root or not Path(root).is_dir():
        return root, {}
    try:
        data = DemoDataset(root)
    except LiberoDataError:
        return root, {}
    found = {}
    for task in data.tasks:
        starts = data.training_starts(task)
        if starts is not None:
            found[task.name] = starts
    return root, found


def _eval_task(task: Any, position: int, heldout: int, avoid: set[int]) -> EvalTask:
    from libero_data.seeding import heldout_starts

    inits = task.init_states() if task.init_states_path is not None else None
    return EvalTask(
        name=task.name,
        language=task.language,
        position=position,
        env_ref=str(task.bddl_path),
        task_emb=np.zeros(1, dtype=np.float32),
        init_states=inits,
        heldout=tuple(heldout_starts(task.name, heldout, avoid=avoid)),
        suite=task.suite,
    )


def _jobs(
    request: EvalRequest,
    tasks: list[EvalTask],
    limits: Mapping[str, int],
    size: int,
    width: int,
    folder: RunFolder,
) -> list[RolloutJob]:
    jobs = []
    for task in tasks:
        stored = request.stored if task.init_states is not None else 0
        for start, count in ((STORED, stored), (HELDOUT, request.heldout)):
            for r in range(count):
                key = f"t{task.position:03d}-{'r' if start == STORED else 'h'}{r:03d}"
                jobs.append(
                    make_job(
                        task,
                        r,
                        key=key,
                        settle=request.settle,
                        max_steps=limits[task.name],
                        image_size=size,
                        sim_state_width=width,
                        shard_dir=folder.shard(key).relative_to(folder.root),
                        rrd_path=folder.rrd_file(key).relative_to(folder.root),
                        tags={"task_position": task.position, "phase": "eval", "policy": request.policy},
                        start=start,
                        render_quality=request.render_quality,
                    )
                )
    return jobs


def evaluate_policy(
    request: EvalRequest,
    out: str | Path,
    *,
    execution: Execution | None = None,
    on_result: Callable[[RolloutResult], None] | None = None,
    on_total: Callable[[int], None] | None = None,
    heldout_seeds: Mapping[str, Sequence[int]] | None = None,
    step_limits: Mapping[str, int] | None = None,
    source: PolicySource | None = None,
    keep_work: bool = False,
) -> dict[str, Any]:
    """Evaluate (or go on evaluating) the policy into ``out``; returns the summary. Once every
    rollout is in ``rollouts/`` the work files (``.work/``: per-rollout shards) are removed
    unless ``keep_work``; the same command on the finished folder then rewrites the report only.

    ``heldout_seeds`` (task name -> seeds) replaces a task's own held-out placements, so that
    variants of one task are rolled out from the same placements (libero_bench.robustness.cells), and
    ``step_limits`` (task name -> steps) replaces a task's step limit (a variant takes its source's);
    ``source`` is the request's policy when the caller has opened it already (``policy_source``)."""
    from libero_data.runtime.versions import versions

    execution = execution or Execution()
    source = source or policy_source(request.policy, request.image_size, request.replan_steps)
    tasks = resolve_tasks(request.tasks)
    dataset, starts = training_starts(Path(source.ref)) if not is_server(source.ref) else (None, {})
    eval_tasks = [
        _eval_task(t, i, request.heldout, starts.get(t.name, (set(), set()))[1]) for i, t in enumerate(tasks)
    ]
    if heldout_seeds:
        eval_tasks = [
            dataclasses.replace(e, heldout=tuple(heldout_seeds[e.name])) if e.name in heldout_seeds else e
            for e in eval_tasks
        ]
    width = max(
        len(e.init_states[0]) if e.init_states is not None else state_width(t)
        for e, t in zip(eval_tasks, tasks, strict=True)
    )
    limits = {e.name: step_limit(request.max_steps, e.suite) for e in eval_tasks}
    limits.update({name: n for name, n in (step_limits or {}).items() if name in limits})
    folder = RunFolder(Path(out).resolve())
    settings = {
        "format": EVAL_FORMAT,
        "request": {**asdict(request), "policy": source.ref, "tasks": list(request.tasks)},
        "policy_type": source.policy_type,
        "inputs": source.inputs,
        "tasks": [
            {
                "position": e.position,
                "name": e.name,
                "language": e.language,
                "bddl": e.env_ref,
                "max_steps": limits[e.name],
            }
            for e in eval_tasks
        ],
        "training_data": dataset,
        "heldout_seeds": {t.name: list(t.heldout) for t in eval_tasks},
    }
    work = WorkFolder(folder.root, "policy evaluation")
    work.claim(
        settings,
        name="config.json",
        owner=folder.root,
        advice="use the same command or another output folder",
    )
    results_path = folder.results
    saved = read_json(results_path, required=("rollouts",)) if results_path.is_file() else {}
    done = saved.get("rollouts", [])
    sessions = saved.get("sessions", [])
    joined = bool(saved.get("complete")) and (folder.rollouts / "meta" / "info.json").is_file()
    finished = {r["key"] for r in done if joined or (folder.shard(r["key"]) / "episode.json").is_file()}
    jobs = [
        j
        for j in _jobs(request, eval_tasks, limits, source.render_size, width, folder)
        if j.key not in finished
    ]
    records = [r for r in done if r["key"] in finished]
    if on_total:
        on_total(len(jobs) + len(records))
    WorkFolder(folder.work, "policy evaluation").clean("shards/*.tmp-*")
    if jobs:
        session = _roll_out(source, jobs, folder, execution, records, sessions, on_result)
        sessions.append(session)
    summary = summarize_eval(settings, records, starts)
    write_json(
        results_path,
        {"rollouts": records, "complete": True, "sessions": sessions, "versions": versions(python=True)},
    )
    _finish(folder, settings, records, summary, rollouts=bool(jobs) or not joined)
    if not keep_work:
        shutil.rmtree(folder.work, ignore_errors=True)
    return summary


def _roll_out(
    source: PolicySource,
    jobs: list[RolloutJob],
    folder: RunFolder,
    execution: Execution,
    records: list[dict[str, Any]],
    sessions: list[dict[str, Any]],
    on_result: Callable[[RolloutResult], None] | None,
) -> dict[str, Any]:
    """Run ``jobs``, appending each finished rollout to ``records`` (and ``results.json``); how
    they ran (batch size, workers, device, the actor) as this session's record."""
    from libero_data.runtime.versions import versions

    actor = source.open(execution.policy_device())
    session: dict[str, Any] = {}
    try:
        with execution.open(folder.root) as environments:
            session = {**environments.describe(), **actor.describe(), "rollouts": 0}
            for i, result in environments.run(actor, jobs):
                records.append(_record(jobs[i], result))
                session["rollouts"] += 1
                write_json(
                    folder.results,
                    {
                        "rollouts": records,
                        "complete": False,
                        "sessions": [*sessions, session],
                        "versions": versions(python=True),
                    },
                )
                if on_result:
                    on_result(result)
    finally:
        actor.close()
    session["forwards"] = actor.forwards
    return session


def _record(job: RolloutJob, result: RolloutResult) -> dict[str, Any]:
    return {
        "key": job.key,
        "task": job.task_name,
        "task_position": job.tags["task_position"],
        "start": job.start,
        "rollout": job.tags["rollout"],
        "init_index": job.init_index,
        "env_seed": job.env_seed,
        "success": result.success,
        "steps": result.steps,
    }


def _finish(
    folder: RunFolder,
    settings: dict[str, Any],
    records: list[dict[str, Any]],
    summary: dict[str, Any],
    *,
    rollouts: bool = True,
) -> None:
    """The rollout dataset (unless it holds every rollout already), the report (Markdown, JSON)
    and its chart."""
    if rollouts:
        _join_rollouts(folder, settings, records)
    write_text(folder.root / "report.md", eval_markdown(summary))
    write_json(folder.root / "report.json", summary)
    chart(summary, folder.root / "success.png")


def _join_rollouts(folder: RunFolder, settings: dict[str, Any], records: list[dict[str, Any]]) -> None:
    from libero_bench.evaluation.rollout_dataset import build_rollout_dataset

    keys = sorted(r["key"] for r in records)
    bddl = {t["name"]: Path(t["bddl"]).read_text() for t in settings["tasks"]}
    meta = {
        "run": folder.root.name,
        "algo": "—",
        "policy": settings["policy_type"],
        "preset": "eval",
        "seed": "—",
        "request": {"repo_id": "libero-bench/rollouts", "suite": "eval"},
        "tasks": settings["tasks"],
    }
    build_rollout_dataset(
        [folder.shard(k) for k in keys], folder.rollouts, run_meta=meta, bddl=bddl, work_dir=folder.work
    )
