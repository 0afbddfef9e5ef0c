"""Measuring the expert: success rate per task over its stored init states.

The work is split by task over worker processes (each builds its own simulator, see
NOTES.md: GL contexts do not survive a fork). Results are plain rows, written as CSV and
Markdown by :func:`libero_data.cards.expert_table.write_report`.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import time
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

# The tables live in libero_data.cards (outside the fingerprint); importable from here as before.
from libero_data.cards.expert_table import TARGETS, TASK_FLOOR, summarise, write_report
from libero_data.experts.expert import ExpertConfig

__all__ = [
    "TARGETS",
    "TASK_FLOOR",
    "ReportJournal",
    "TaskResult",
    "evaluate_task",
    "run_report",
    "summarise",
    "write_report",
]

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

    @property
    def rate(self) -> float:
        return self.successes / self.episodes if self.episodes else 0.0


def episode_seeds(seed: int, task_key: str, init_index: int) -> tuple[int, int]:
    """(reset seed, expert seed) of one episode: stable across runs, machines and workers."""
    ss = np.random.SeedSequence([seed, _stable_hash(task_key), init_index])
    a, b = ss.generate_state(2)
    return int(a), int(b)


def _stable_hash(text: str) -> int:
    import hashlib

    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "little")


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
            else:
                failures[_reason(episode.failure)] += 1
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
    )


def expert_fingerprint() -> str:
    """A short hash of the code that decides an episode (expert and simulator sources).

    A resumed report only keeps rows measured by the same code. Comments and docstrings do
    not count: rewording one does not throw measured tasks away.
    """
    root = Path(__file__).resolve().parents[1]
    return code_digest(sorted(p for sub in ("experts", "sim") for p in (root / sub).rglob("*.py")), root)


def code_digest(paths: Iterable[Path], root: Path) -> str:
    """12 hex digits of sha256 over the files' paths (relative to ``root``) and their code,
    with comments, docstrings and formatting left out (the code as Python reads it)."""
    import ast

    digest = hashlib.sha256()
    for path in paths:
        tree = ast.parse(path.read_bytes(), filename=str(path))
        for node in ast.walk(tree):
            body = getattr(node, "body", None)
            if (
                isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef)
                and body
                and isinstance(body[0], ast.Expr)
                and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)
            ):
                node.body = body[1:] or [ast.Pass()]
        digest.update(Path(path).relative_to(root).as_posix().encode())
        digest.update(ast.unparse(tree).encode())
    return digest.hexdigest()[:12]


class ReportJournal:
    """``expert_report.jsonl``: a settings header, then one line per finished task.

    Each line is written and synced as its task finishes, so an interrupted report keeps
    every finished task; running the same command again measures only the rest.
    """

    NAME = "expert_report.jsonl"

    def __init__(self, out_dir: str | Path, settings: dict[str, object], *, fresh: bool = False) -> None:
        self.path = Path(out_dir) / self.NAME
        self.settings = settings
        self.done: dict[str, TaskResult] = {}
        if self.path.exists() and not fresh:
            self._load()
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._write_lines([json.dumps({"settings": settings})], mode="w")

    def _load(self) -> None:
        lines = self.path.read_text().splitlines()
        try:
            header = json.loads(lines[0])["settings"] if lines else None
        except (json.JSONDecodeError, KeyError, TypeError):
            header = None
        if header is None:
            raise ValueError(f"{self.path} is not an expert report journal; pass --fresh to start over")
        if header != self.settings:
            changed = sorted(
                k for k in set(header) | set(self.settings) if header.get(k) != self.settings.get(k)
            )
            raise ValueError(
                f"{self.path} was measured with different settings ({', '.join(changed)}); "
                "pass --fresh to start over or use another --out"
            )
        for line in lines[1:]:
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue  # a line cut by a kill: that task is measured again
            ref = row.pop("ref")
            self.done[ref] = TaskResult(**row)
        text = self.path.read_text()
        if not text.endswith("\n"):  # drop the cut line so the next one starts on its own
            self.path.write_text(text[: text.rfind("\n") + 1])

    def _write_lines(self, lines: list[str], mode: str = "a") -> None:
        with self.path.open(mode) as f:
            for line in lines:
                f.write(line + "\n")
            f.flush()
            os.fsync(f.fileno())

    def add(self, ref: str, result: TaskResult) -> None:
        self._write_lines([json.dumps({"ref": ref, **asdict(result)})])
        self.done[ref] = result


def _reason(text: str | None) -> str:
    """A failure message as the table shows it (kept whole: within one task the names in it
    are the same from episode to episode, so equal failures still group)."""
    if not text:
        return "unknown"
    return " ".join(text.split())[:100]


def _worker(args: tuple[str, int, int, ExpertConfig, str]) -> tuple[str, TaskResult]:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    ref, inits, seed, config, fingerprint = args
    # Worker processes are replaced every few tasks and import the code afresh: a task
    # measured with code edited since the report started must not join its rows.
    now = expert_fingerprint()
    if now != fingerprint:
        raise ValueError(
            f"the expert's code changed while the report ran (was {fingerprint}, now {now}); "
            f"{ref} was not measured. Run the command again to go on with the new code (--fresh)"
        )
    return ref, evaluate_task(ref, inits, seed=seed, config=config)


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
    refs = list(task_refs)
    config = config or ExpertConfig()
    fingerprint = fingerprint or expert_fingerprint()
    jobs = [(ref, inits, seed, config, fingerprint) for ref in refs]
    results: dict[str, TaskResult] = {}
    if workers <= 1:
        for job in jobs:
            ref, result = _worker(job)
            results[ref] = result
            if on_task:
                on_task(ref, result)
    else:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(workers, maxtasksperchild=4) as pool:
            for ref, result in pool.imap_unordered(_worker, jobs):
                results[ref] = result
                if on_task:
                    on_task(ref, result)
    return [results[r] for r in refs]
