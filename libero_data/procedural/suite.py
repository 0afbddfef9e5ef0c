"""A procedural suite on disk: sample, prove feasible with the expert, write BDDL + init states.

Layout of the output folder (it is also where the dataset goes):

- ``tasks/<name>.bddl`` and ``tasks/<name>.init.npz`` (sampled initial states, LIBERO's
  sampler, seeded) for every kept task;
- ``suite.json``: the kept tasks in order (what ``get_suite(folder)`` reads) and the
  generator's seed and settings;
- ``procedural_report.json`` / ``.md``: every candidate with its scene, template, expert
  result and, when rejected, why.

Each candidate's verdict is journalled under ``.libero-data/procedural/`` as soon as it is
known, so an interrupted run resumes without testing a task twice.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.procedural.sampler import SampledTask, sample_tasks

SUITE_FILES = ("suite.json", "tasks", "procedural_report.json", "procedural_report.md")
WORK = ".libero-data"


@dataclass(frozen=True)
class ProceduralSettings:
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

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        for key in ("scenes", "templates", "kinds", "tasks"):
            d[key] = list(d[key])
        return d


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


def _seed(settings: ProceduralSettings, name: str, i: int) -> int:
    import hashlib

    h = int.from_bytes(hashlib.sha256(name.encode()).digest()[:4], "little")
    return int(np.random.SeedSequence([settings.seed, h, i]).generate_state(1)[0])


def check_task(
    bddl_path: Path, name: str, language: str, settings: ProceduralSettings
) -> tuple[Verdict, np.ndarray | None]:
    """Sample initial states with LIBERO's sampler and try the expert on the first few."""
    from libero_data.experts import Expert
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks.registry import Task

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
                env.reset(None, seed=_seed(settings, name, i), render=False)
            except Exception as exc:  # LIBERO's placement sampler gave up
                verdict.reason = f"placement impossible: {type(exc).__name__}"
                return verdict, None
            states.append(env.get_state())
        expert = Expert(env)
        need = (settings.check_inits + 1) // 2
        for i in range(settings.check_inits):
            episode = expert.run(
                states[i], reset_seed=_seed(settings, name, i), seed=_seed(settings, name, 1000 + i)
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


def _check_worker(args: tuple[str, str, str, dict[str, Any]]) -> tuple[Verdict, np.ndarray | None]:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    path, name, language, settings = args
    s = dict(settings)
    for key in ("scenes", "templates", "kinds", "tasks"):
        s[key] = tuple(s[key])
    return check_task(Path(path), name, language, ProceduralSettings(**s))


def make_suite(
    out: str | Path,
    settings: ProceduralSettings,
    *,
    workers: int = 1,
    on_verdict: Callable[[Verdict], None] | None = None,
) -> list[Verdict]:
    """Sample, check and write the suite into ``out``; resumes an interrupted run."""
    from libero_data.bddl.writer import _formula, write
    from libero_data.experts.report import expert_fingerprint

    expert_code = expert_fingerprint()  # of the code this process runs (read before any check)
    out = Path(out).resolve()
    work = out / WORK / "procedural"
    work.mkdir(parents=True, exist_ok=True)
    saved = work / "settings.json"
    if saved.is_file():
        if json.loads(saved.read_text()) != settings.to_json():
            raise ValueError(
                f"{out} holds a procedural suite made with other settings; use the same command or another --out"
            )
    else:
        saved.write_text(json.dumps(settings.to_json(), indent=2))
    candidates: list[tuple[SampledTask | None, str, str, str]]
    if settings.variants_of:
        from libero_data.procedural.variants import variant_tasks

        candidates = list(
            variant_tasks(settings.variants_of, settings.kinds, settings.seed, settings.tasks or None)
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
        raise ValueError("two sampled tasks share a name; this is a bug in the sampler")
    staged = work / "bddl"
    staged.mkdir(exist_ok=True)
    verdicts: dict[int, Verdict] = {}
    states: dict[int, np.ndarray] = {}
    jobs = []
    for i, (task, scene, template, why) in enumerate(candidates):
        if task is None:
            verdicts[i] = Verdict(f"candidate_{i}", scene, template, "", False, why)
            continue
        done = work / f"{i:04d}.json"
        if done.is_file():
            verdicts[i] = Verdict(**json.loads(done.read_text()))
            if verdicts[i].kept:
                with np.load(work / f"{i:04d}.npz") as data:
                    states[i] = data["states"]
            continue
        path = staged / f"{task.name}.bddl"
        path.write_text(write(task.problem))
        jobs.append((i, (str(path), task.name, task.language, settings.to_json())))
    for v in verdicts.values():
        if on_verdict:
            on_verdict(v)

    def record(i: int, verdict: Verdict, st: np.ndarray | None) -> None:
        task = candidates[i][0]
        assert task is not None
        verdict.scene, verdict.template = task.scene, task.template
        verdict.goal = _formula(task.problem.goal)
        if verdict.kept and st is not None:
            tmp = work / f"{i:04d}.tmp.npz"
            np.savez(tmp, states=st)
            tmp.replace(work / f"{i:04d}.npz")
            states[i] = st
        tmp_json = work / f"{i:04d}.json.tmp"
        tmp_json.write_text(json.dumps(asdict(verdict)))
        tmp_json.replace(work / f"{i:04d}.json")
        verdicts[i] = verdict
        if on_verdict:
            on_verdict(verdict)

    if workers <= 1:
        for i, job in jobs:
            v, st = _check_worker(job)
            record(i, v, st)
    else:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(workers, maxtasksperchild=8) as pool:
            index = {job[1]: i for i, job in jobs}
            for v, st in pool.imap_unordered(_check_worker, [job for _, job in jobs]):
                record(index[v.name], v, st)

    ordered = [verdicts[i] for i in range(len(candidates))]
    _write_suite(out, settings, candidates, ordered, states, expert_code)
    return ordered


def _write_suite(
    out: Path,
    settings: ProceduralSettings,
    candidates: list[tuple[SampledTask | None, str, str, str]],
    verdicts: list[Verdict],
    states: dict[int, np.ndarray],
    expert_code: str = "",
) -> None:
    from libero_data.bddl.writer import write

    tasks_dir = out / "tasks"
    tasks_dir.mkdir(exist_ok=True)
    entries = []
    for i, (task, v) in enumerate(zip([c[0] for c in candidates], verdicts, strict=True)):
        if task is None or not v.kept:
            continue
        (tasks_dir / f"{task.name}.bddl").write_text(write(task.problem))
        np.savez(tasks_dir / f"{task.name}.init.npz", states=states[i])
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
    from libero_data.pipeline.generate import versions

    manifest = {
        "name": out.name,
        "generator": {
            "settings": settings.to_json(),
            "versions": versions(),
            "candidates": len(verdicts),
            "expert_code": expert_code,
        },
        "tasks": entries,
    }
    tmp = out / "suite.json.tmp"
    tmp.write_text(json.dumps(manifest, indent=1))
    tmp.replace(out / "suite.json")
    report = {"settings": settings.to_json(), "candidates": [asdict(v) for v in verdicts]}
    (out / "procedural_report.json").write_text(json.dumps(report, indent=1))
    (out / "procedural_report.md").write_text(report_markdown(verdicts, settings, expert_code))


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
