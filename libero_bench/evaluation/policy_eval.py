"""``libero-bench eval``: a policy (a libero-bench run, a LeRobot policy folder, or one served over
openpi's websocket protocol) evaluated on tasks, suites, generated suites or robustness variants,
under an evaluation protocol (:mod:`libero_bench.rollouts.protocol`). The policy runs once, batched
over the environments (:mod:`libero_bench.rollouts`); ``results.json`` records how each session ran
(batch size, workers, device, forward passes).

Under the default protocol every task is rolled out from LIBERO's stored init states (where it has
them) and from held-out placements (``libero_data.seeding.heldout_starts``, skipping the seeds the
policy's training demonstrations started from, where they are known). Under the standard protocol
episode ``i`` starts from stored init state ``i`` as openpi's LIBERO client starts it. Every
rollout is stored like a demonstration (``rollouts/``: one LeRobot dataset, an MCAP log each;
``rrd/``: a Rerun recording each); ``results.json`` lists them, and the report gives every task's
success with n and a 95% Wilson interval. The folder resumes after an interruption
(:class:`~libero_bench.rollouts.session.RolloutSession`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.evaluation.eval_report import chart, eval_markdown, summarize_eval
from libero_bench.rollouts.jobs import EvalTask, RolloutJob, RolloutResult, make_job
from libero_bench.rollouts.loop import RolloutResources
from libero_bench.rollouts.policy_kinds import RUN, SERVER, PolicySource, policy_source, shown_from
from libero_bench.rollouts.protocol import LIBERO_BENCH, PROTOCOLS, Protocol, get_protocol
from libero_bench.rollouts.session import Group, RolloutSession, rollout_record
from libero_bench.runs.folder import HELDOUT, STANDARD, STORED
from libero_data.errors import InputError, LiberoDataError
from libero_data.pipeline.request import state_width
from libero_data.rollout import RolloutSettings
from libero_data.runtime.files import read_json, write_json, write_text
from libero_data.runtime.folder import WorkFolder
from libero_data.tasks.horizons import SUITE, step_limit

EVAL_FORMAT = "libero-bench-eval/1"


@dataclass(frozen=True)
class EvalRequest(RolloutSettings):
    """What to evaluate: a policy (a run folder, a LeRobot policy folder or a server, ``ws://HOST:
    PORT``) on tasks, under ``protocol``: the default's starts of each kind (``stored``, ``heldout``)
    or the standard protocol's ``trials`` per task, with the shared rollout settings (``max_steps``,
    ``settle``, ``render_quality``: :class:`~libero_data.rollout.RolloutSettings`). For a server,
    ``image_size`` is the camera size sent (default: the size the server's metadata names, else 224,
    openpi's) and ``replan_steps`` the actions executed of each chunk it returns (openpi's LIBERO
    client: 5). ``prompt``: each task's instruction, or (``file-name``) the words of its file name as
    LIBERO-Plus's benchmark sends them (:func:`libero_data.tasks.plus.file_name_prompt`)."""

    policy: str
    tasks: tuple[str, ...]
    stored: int = 20
    heldout: int = 20
    image_size: int | None = None
    replan_steps: int = 5
    protocol: str = LIBERO_BENCH
    trials: int = 50
    prompt: str = "instruction"

    def __post_init__(self) -> None:
        super().__post_init__()
        get_protocol(self.protocol)
        from libero_data.tasks.plus import PROMPTS

        if self.prompt not in PROMPTS:
            raise InputError(
                f"the prompt is one of {', '.join(PROMPTS)}, not {self.prompt!r}", field="prompt"
            )
        if self.replan_steps < 1:
            raise InputError("execute at least one action of each chunk", field="replan_steps")
        if self.image_size is not None and self.image_size < 8:
            raise InputError(
                f"the image size must be at least 8 pixels, got {self.image_size}", field="image_size"
            )
        if not self.tasks:
            raise InputError("no tasks to evaluate on", field="tasks")
        for name in ("stored", "heldout", "trials"):
            if getattr(self, name) < 0:
                raise InputError(f"the number of {name} must not be negative", field=name)
        if self.counts() and not any(self.counts().values()):
            raise InputError(
                "evaluate from at least one start", field="trials" if self.is_standard else "stored"
            )

    @property
    def is_standard(self) -> bool:
        return get_protocol(self.protocol).standard

    def counts(self) -> dict[str, int]:
        """Rollouts per task from each kind of start."""
        if self.is_standard:
            return {STANDARD: self.trials}
        return {STORED: self.stored, HELDOUT: self.heldout}

    def deviations(self) -> list[str]:
        """Where this request leaves its protocol's standard (empty for the default protocol)."""
        protocol = get_protocol(self.protocol)
        if not protocol.standard:
            return []
        out = []
        if self.max_steps != SUITE:
            out.append(f"a step limit of {self.max_steps} instead of the suite's")
        if self.settle != protocol.settle:
            out.append(f"{self.settle} waiting steps instead of {protocol.settle}")
        if self.render_quality != "full":
            out.append(f"{self.render_quality} rendering (LIBERO's pixels are full rendering's)")
        if self.replan_steps != protocol.replan_steps:
            out.append(f"{self.replan_steps} actions of each chunk instead of {protocol.replan_steps}")
        if self.image_size not in (None, protocol.sent_size):
            out.append(f"images sent at {self.image_size} instead of {protocol.sent_size}")
        return out


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
    for task in out:
        task.require_buildable()  # a LIBERO-Plus task without its asset: one sentence naming it
    names = [t.name for t in out]
    if len(set(names)) != len(names):
        raise InputError(
            "the task list names a task twice (a LIBERO-PRO suite's tasks have its base suite's names: "
            "evaluate each suite in its own folder)",
            field="tasks",
        )
    return out


def _eval_task(
    task: Any, position: int, heldout: int, avoid: set[int], embedding: np.ndarray, language: str
) -> EvalTask:
    from libero_data.seeding import heldout_starts

    inits = task.init_states() if task.init_states_path is not None else None
    return EvalTask(
        name=task.name,
        language=language,
        position=position,
        env_ref=str(task.bddl_path),
        task_emb=embedding,
        init_states=inits,
        heldout=tuple(heldout_starts(task.name, heldout, avoid=avoid)),
        suite=task.suite,
    )


def _jobs(
    request: EvalRequest,
    protocol: Protocol,
    tasks: list[EvalTask],
    limits: Mapping[str, int],
    size: int,
    width: int,
    session: RolloutSession,
) -> list[RolloutJob]:
    folder = session.folder
    jobs = []
    for task in tasks:
        for start, count in request.counts().items():
            if start == STORED and task.init_states is None:
                continue
            for r in range(count):
                key = f"t{task.position:03d}-{start[0]}{r:03d}"
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
                        limits=protocol.limits,
                    )
                )
    return jobs


def beyond_openpi(source: PolicySource) -> list[str]:
    """The request entries a standard evaluation sends beyond openpi's four: what the policy
    reads (a local one) or what the server's metadata asks for (a served one)."""
    from libero_bench.rollouts.observations import EXTRA_ENTRIES, extra_needs

    if source.kind == SERVER:
        return list(source.inputs.get("beyond_openpi", []))
    return [EXTRA_ENTRIES[k] for k in extra_needs(source.reads)]


def _groups(
    source: PolicySource, request: EvalRequest, protocol: Protocol, jobs: list[RolloutJob]
) -> list[Group]:
    """The jobs grouped by the actor that acts for them (a run's per-task evaluation view), each
    actor wrapped in the protocol's request mapping where it runs here."""
    from libero_bench.rollouts.observations import OBSERVATION_KEYS, RequestView, extra_needs

    def opener(view: int | None) -> Callable[[str], Any]:
        def open_actor(device: str) -> Any:
            actor = source.open(device, view)
            if not protocol.standard or source.kind == SERVER:
                return actor
            carried = set(OBSERVATION_KEYS.values())
            foreign = [k for k in source.reads if k not in carried]
            if foreign:
                raise InputError(
                    f"the {source.policy_type} policy reads {', '.join(foreign)}, which openpi's request "
                    "cannot carry; evaluate it under the libero-bench protocol",
                    field="protocol",
                )
            needs = extra_needs(source.reads)
            size = source.render_size if source.kind == RUN else None
            return RequestView(actor, sent_size=request.image_size or 224, image_size=size, needs=needs)

        return open_actor

    by_view: dict[int | None, list[RolloutJob]] = {}
    for job in jobs:
        by_view.setdefault(source.view_of(job.task_name), []).append(job)
    return [
        (opener(view), group)
        for view, group in sorted(by_view.items(), key=lambda e: (e[0] is None, e[0] or 0))
    ]


def evaluate_policy(
    request: EvalRequest,
    out: str | Path,
    *,
    execution: RolloutResources | None = None,
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
    protocol = PROTOCOLS[request.protocol]
    execution = execution or RolloutResources()
    source = source or policy_source(
        request.policy, request.image_size, request.replan_steps, protocol.request
    )
    tasks = resolve_tasks(request.tasks)
    dataset, starts, eval_tasks = _eval_tasks(request, source, tasks, heldout_seeds)
    width = max(
        len(e.init_states[0]) if e.init_states is not None else state_width(t)
        for e, t in zip(eval_tasks, tasks, strict=True)
    )
    limits = {e.name: step_limit(request.max_steps, e.suite, protocol.limits) for e in eval_tasks}
    limits.update({name: n for name, n in (step_limits or {}).items() if name in limits})
    session = RolloutSession(Path(out).resolve())
    settings = {
        "format": EVAL_FORMAT,
        "request": {**asdict(request), "policy": source.ref, "tasks": list(request.tasks)},
        "policy_type": source.policy_type,
        "policy_kind": source.kind,
        "inputs": source.inputs,
        "protocol": {"name": protocol.name, "deviations": request.deviations()},
        "tasks": [
            {
                "position": e.position,
                "name": e.name,
                "suite": e.suite,
                "language": e.language,
                "bddl": e.env_ref,
                "max_steps": limits[e.name],
            }
            for e in eval_tasks
        ],
        "training_data": dataset,
        "heldout_seeds": {t.name: list(t.heldout) for t in eval_tasks},
    }
    WorkFolder(session.root, "policy evaluation").claim(
        settings,
        name="config.json",
        owner=session.root,
        advice="use the same command or another output folder",
    )
    session.load()
    size = protocol.render_size or source.render_size
    jobs = session.left(_jobs(request, protocol, eval_tasks, limits, size, width, session))
    if on_total:
        on_total(len(jobs) + len(session.records))
    if jobs:
        session.run(
            execution,
            _groups(source, request, protocol, jobs),
            lambda job, result: rollout_record(job, result, task_position=job.tags["task_position"]),
            on_result,
        )
    summary = summarize_eval(settings, [session.records[k] for k in sorted(session.records)], starts)
    summary["policy"] = shown_from(source.ref, session.root)  # found from the folder, moved or not
    summary["policy_given"] = request.policy  # as the user named it (report.md shows this)
    if protocol.standard:
        summary["beyond_openpi"] = beyond_openpi(source)
    if jobs or not session.joined:
        session.join(
            _rollouts_meta(session.root, settings),
            {e.name: Path(e.env_ref).read_text() for e in eval_tasks},
        )
    session.save(complete=True)
    write_text(session.root / "report.md", eval_markdown(summary))
    write_json(session.root / "report.json", summary)
    chart(summary, session.root / "success.png")
    session.clean(keep_work)
    return summary


def _eval_tasks(
    request: EvalRequest,
    source: PolicySource,
    tasks: list[Any],
    heldout_seeds: Mapping[str, Sequence[int]] | None,
) -> tuple[str | None, dict[str, tuple[set[int], set[int]]], list[EvalTask]]:
    """The policy's training data and starts, and how each task is rolled out (its embedding, its
    held-out placements: ``heldout_seeds`` where given, else seeds no demonstration started from)."""
    try:
        dataset, starts = source.training_starts()
    except LiberoDataError:
        if HELDOUT in request.counts() and request.heldout:
            raise  # held-out placements must avoid the training data's: it has to be found
        dataset, starts = None, {}
    from libero_data.tasks.plus import file_name_prompt

    prompts = [t.language if request.prompt == "instruction" else file_name_prompt(t) for t in tasks]
    embeddings = (
        source.embed(prompts) if source.embed is not None else np.zeros((len(tasks), 1), dtype=np.float32)
    )
    eval_tasks = [
        _eval_task(t, i, request.heldout, starts.get(t.name, (set(), set()))[1], embeddings[i], prompts[i])
        for i, t in enumerate(tasks)
    ]
    if heldout_seeds:
        eval_tasks = [
            dataclasses.replace(e, heldout=tuple(heldout_seeds[e.name])) if e.name in heldout_seeds else e
            for e in eval_tasks
        ]
    return dataset, starts, eval_tasks


def _rollouts_meta(root: Path, settings: dict[str, Any]) -> dict[str, Any]:
    return {
        "kind": "evaluation",
        "run": root.name,
        "policy": settings["policy_type"],
        "policy_ref": settings["request"]["policy"],
        "protocol": (settings.get("protocol") or {}).get("name", LIBERO_BENCH),
        "request": {"repo_id": "libero-bench/rollouts", "suite": "eval"},
        "tasks": settings["tasks"],
    }


def is_eval_folder(folder: str | Path) -> bool:
    """Whether ``folder`` holds a policy evaluation (``libero-bench eval``'s ``config.json``)."""
    try:
        return bool(read_json(Path(folder) / "config.json").get("format") == EVAL_FORMAT)
    except (LiberoDataError, OSError, ValueError, AttributeError):
        return False


def eval_task_rollouts(folder: str | Path, ref: str) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """A task of an evaluation (by name or position) and its rollouts' records, in key order
    (their Rerun recordings: ``FOLDER/rrd/<key>.rrd``)."""
    from libero_bench.runs.folder import find_task

    config = read_json(Path(folder) / "config.json", required=("tasks",))
    chosen = find_task(config, ref)
    mine = sorted(
        (r for r in eval_records(folder) if r.get("task_position") == chosen["position"]),
        key=lambda r: r["key"],
    )
    if not mine:
        raise InputError(f"task {chosen['name']} has no finished rollouts in {folder} yet", field="task")
    return chosen, mine


def eval_records(folder: str | Path) -> list[dict[str, Any]]:
    """The rollout records of a finished evaluation folder."""
    return list(read_json(Path(folder) / "results.json", required=("rollouts",))["rollouts"])
