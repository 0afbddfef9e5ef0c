"""A procedural suite on disk: sample, prove feasible with the expert, write BDDL + init states.

Layout of the output folder (it is also where the dataset goes):

- ``tasks/<name>.bddl`` and ``tasks/<name>.init.npz`` (sampled initial states, LIBERO's
  sampler, seeded) for every kept task;
- ``suite.json``: the kept tasks in order (what ``get_suite(folder)`` reads) and the
  generator's seed and settings;
- ``procedural_report.json`` / ``.md``: every candidate with its scene, template, expert
  result and, when rejected, why.

Each candidate's verdict is journalled under ``.libero-data/procedural/`` as soon as it is
known, so an interrupted run resumes without testing a task twice. Candidates are checked as
jobs of the runtime's job runner.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from libero_data.config import Config
from libero_data.errors import SettingsChanged
from libero_data.runtime.files import save_npz, write_json, write_text
from libero_data.runtime.folder import DATASET_WORK, WorkFolder, changed_keys
from libero_data.runtime.jobs import JobPlacement, JobRunner, WorkerContext
from libero_data.scenes.sampler import SampledTask, sample_tasks
from libero_data.seeding import CANDIDATE_EXPERT, candidate_seed
from libero_data.tasks import SUITE_MANIFEST


@dataclass(frozen=True)
class ProceduralSettings(Config):
    n: int
    seed: int = 0
    scenes: tuple[str, ...] = ()
    templates: tuple[str, ...] = ()
    check_inits: int = 4  # initial states the expert is tried on; kept if it solves half
    stored_inits: int = 10  # initial states stored with each kept task
    max_distractors: int = 2
    variants_of: str = ""  # a suite: make robustness variants of its tasks instead of new tasks
    kinds: tuple[str, ...] = ()  # variant kinds (``libero_data.procedural.variants.KINDS``)
    tasks: tuple[str, ...] = ()  # with variants_of: which tasks (default all)
    levels: tuple[int, ...] = (1,)  # with variants_of: severity levels 1..5 (libero_data.perturb.levels)

    #: What settings saved before a field existed meant (a suite made then continues).
    legacy: ClassVar[dict[str, Any]] = {"levels": [1]}


@dataclass
class Verdict:
    name: str
    scene: str
    template: str
    language: str
    kept: bool
    reason: str = ""
    successes: int = 0
    tried: int = 0
    goal: str = ""
    failures: list[str] = field(default_factory=list)


def check_task(
    bddl_path: Path, name: str, language: str, settings: ProceduralSettings
) -> tuple[Verdict, np.ndarray | None]:
    """Sample initial states with LIBERO's sampler and try the expert on the first few."""
    from libero_data.experts import Expert
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks.suites import Task

    task = Task("procedural", 0, name, language, bddl_path)
    verdict = Verdict(name, "", "", language, False)
    states = []
    try:
        env = LiberoEnv(task, EnvConfig(cameras=()))
    except Exception as exc:  # LIBERO cannot build the scene at all
        verdict.reason = f"scene does not build: {type(exc).__name__}: {str(exc)[:120]}"
        return verdict, None
    with env:
        for i in range(settings.stored_inits):
            try:
                env.reset(None, seed=candidate_seed(settings.seed, name, i), render=False)
            except Exception as exc:  # LIBERO's placement sampler gave up
                verdict.reason = f"placement impossible: {type(exc).__name__}"
                return verdict, None
            states.append(env.get_state())
        expert = Expert(env)
        need = (settings.check_inits + 1) // 2
        for i in range(settings.check_inits):
            episode = expert.run(
                states[i],
                reset_seed=candidate_seed(settings.seed, name, i),
                seed=candidate_seed(settings.seed, name, CANDIDATE_EXPERT + i),
            )
            verdict.tried += 1
            verdict.successes += bool(episode.success)
            if not episode.success:
                verdict.failures.append(episode.failure or "unknown")
            if verdict.successes >= need or verdict.tried - verdict.successes > settings.check_inits - need:
                break
        verdict.kept = verdict.successes >= need
        if not verdict.kept:
            verdict.reason = f"expert failed: {verdict.successes}/{verdict.tried} ({verdict.failures[0][:80] if verdict.failures else ''})"
    return verdict, np.stack(states)


@dataclass(frozen=True)
class _CheckJob:
    index: int  # the candidate's place in the sample
    bddl: str
    name: str
    language: str
    settings: ProceduralSettings


def _check(ctx: WorkerContext, job: _CheckJob) -> tuple[Verdict, np.ndarray | None]:
    return check_task(Path(job.bddl), job.name, job.language, job.settings)


def make_suite(
    out: str | Path,
    settings: ProceduralSettings,
    *,
    workers: int = 1,
    on_verdict: Callable[[Verdict], None] | None = None,
    executor: JobPlacement | None = None,
) -> list[Verdict]:
    """Sample, check and write the suite into ``out``; resumes an interrupted run.

    Candidates are checked in ``workers`` processes (or with ``executor``)."""
    from libero_data.bddl import formula_text, write
    from libero_data.provenance import expert_code

    code = expert_code()  # of the code this process runs (read before any check)
    out = Path(out).resolve()
    folder = WorkFolder(out / DATASET_WORK / "procedural", "procedural suite")
    done = _finished(out, folder, settings)
    if done is not None:  # made before, its work files removed with its dataset's
        for verdict in done:
            if on_verdict:
                on_verdict(verdict)
        return done
    folder.claim(settings.to_dict(), owner=out, legacy=ProceduralSettings.legacy)
    candidates = _candidates(settings)
    verdicts: dict[int, Verdict] = {}
    states: dict[int, np.ndarray] = {}
    jobs = []
    for i, (task, scene, template, why) in enumerate(candidates):
        if task is None:
            verdicts[i] = Verdict(f"candidate_{i}", scene, template, "", False, why)
        elif folder.path(f"{i:04d}.json").is_file():
            verdicts[i] = Verdict(**json.loads(folder.path(f"{i:04d}.json").read_text()))
            if verdicts[i].kept:
                with np.load(folder.path(f"{i:04d}.npz")) as data:
                    states[i] = data["states"]
        else:
            path = write_text(folder.path("bddl", f"{task.name}.bddl"), write(task.problem))
            jobs.append(_CheckJob(i, str(path), task.name, task.language, settings))
    for v in verdicts.values():
        if on_verdict:
            on_verdict(v)
    with JobRunner(executor or JobPlacement("local", workers), folder.root) as runner:
        for j, (verdict, found) in runner.run(_check, jobs):
            i = jobs[j].index
            task = candidates[i][0]
            assert task is not None
            verdict.scene, verdict.template = task.scene, task.template
            verdict.goal = formula_text(task.problem.goal)
            if verdict.kept and found is not None:
                states[i] = found
                save_npz(folder.path(f"{i:04d}.npz"), states=found)
            write_json(folder.path(f"{i:04d}.json"), asdict(verdict), indent=None, newline=False)
            verdicts[i] = verdict
            if on_verdict:
                on_verdict(verdict)
    ordered = [verdicts[i] for i in range(len(candidates))]
    _write_suite(out, settings, candidates, ordered, states, code)
    return ordered


def _finished(out: Path, folder: WorkFolder, settings: ProceduralSettings) -> list[Verdict] | None:
    """The verdicts of the suite already written in ``out`` by these settings, if it is there
    and its work folder is gone; :class:`SettingsChanged` where other settings made it."""
    manifest, report = out / SUITE_MANIFEST, out / "procedural_report.json"
    if folder.root.exists() or not manifest.is_file() or not report.is_file():
        return None
    made = ProceduralSettings.upgrade(json.loads(manifest.read_text())["generator"]["settings"])
    changed = changed_keys(made, settings.to_dict())
    if changed:
        raise SettingsChanged(
            f"{out} holds a procedural suite made with different settings ({', '.join(changed)}); "
            "use the same command to continue it, or another output folder",
            changed=changed,
        )
    return [Verdict(**v) for v in json.loads(report.read_text())["candidates"]]


def _candidates(settings: ProceduralSettings) -> list[tuple[SampledTask | None, str, str, str]]:
    """The sampled tasks (or variants) in order: (task or None, scene, template, why not)."""
    candidates: list[tuple[SampledTask | None, str, str, str]]
    if settings.variants_of:
        from libero_data.procedural.variants import variant_tasks

        candidates = list(
            variant_tasks(
                settings.variants_of, settings.kinds, settings.seed, settings.tasks or None, settings.levels
            )
        )
    else:
        candidates = list(
            sample_tasks(
                settings.n,
                settings.seed,
                scenes=settings.scenes or None,
                templates=settings.templates or None,
                max_distractors=settings.max_distractors,
            )
        )
    names = [c[0].name for c in candidates if c[0] is not None]
    if len(set(names)) != len(names):  # each task is a file named after it
        raise RuntimeError("two sampled tasks share a name; this is a bug in the sampler")
    return candidates


def _write_suite(
    out: Path,
    settings: ProceduralSettings,
    candidates: list[tuple[SampledTask | None, str, str, str]],
    verdicts: list[Verdict],
    states: dict[int, np.ndarray],
    expert_code: str = "",
) -> None:
    from libero_data.bddl import write
    from libero_data.runtime.versions import versions

    entries = []
    for i, (task, v) in enumerate(zip([c[0] for c in candidates], verdicts, strict=True)):
        if task is None or not v.kept:
            continue
        write_text(out / "tasks" / f"{task.name}.bddl", write(task.problem))
        save_npz(out / "tasks" / f"{task.name}.init.npz", states=states[i])
        entries.append(
            {
                "name": task.name,
                "language": task.language,
                "bddl": f"tasks/{task.name}.bddl",
                "init_states": f"tasks/{task.name}.init.npz",
                "scene": task.scene,
                "template": task.template,
                "expert": [v.successes, v.tried],
            }
        )
    manifest = {
        "name": out.name,
        "generator": {
            "settings": settings.to_dict(),
            "versions": versions(),
            "candidates": len(verdicts),
            "expert_code": expert_code,
        },
        "tasks": entries,
    }
    write_text(out / SUITE_MANIFEST, json.dumps(manifest, indent=1))
    report = {"settings": settings.to_dict(), "candidates": [asdict(v) for v in verdicts]}
    write_text(out / "procedural_report.json", json.dumps(report, indent=1))
    write_text(out / "procedural_report.md", report_markdown(verdicts, settings, expert_code))


def report_markdown(verdicts: list[Verdict], settings: ProceduralSettings, expert_code: str = "") -> str:
    kept = [v for v in verdicts if v.kept]
    scenes = sorted({v.scene for v in kept})
    templates = sorted({v.template for v in kept})
    what = f"variants of {settings.variants_of}" if settings.variants_of else "sampled"
    lines = [
        "# Procedural tasks: acceptance"
        if not settings.variants_of
        else f"# Variants of {settings.variants_of}: acceptance",
        "",
        f"Seed {settings.seed}; {len(verdicts)} {what}, **{len(kept)} kept** "
        f"({len(kept) / max(len(verdicts), 1):.0%}) across {len(scenes)} scenes and {len(templates)} behaviour templates. "
        f"A task is kept when the expert solves at least half of {settings.check_inits} initial states drawn by LIBERO's sampler"
        + (
            f" (expert code {expert_code}, as `libero-data expert-report` prints it)." if expert_code else "."
        ),
        "",
        "| # | task | scene (or source task) | template | expert | verdict |",
        "|---:|---|---|---|---:|---|",
    ]
    for i, v in enumerate(verdicts):
        expert = f"{v.successes}/{v.tried}" if v.tried else "—"
        lines.append(
            f"| {i} | {v.language or '—'} | {v.scene} | {v.template} | {expert} | {'kept' if v.kept else v.reason} |"
        )
    return "\n".join(lines) + "\n"
