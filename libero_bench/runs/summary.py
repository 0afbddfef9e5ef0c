"""A finished (or partly finished) run as the report and the comparison read it."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.runs.folder import STORED, RunFolder, RunResults
from libero_bench.runs.intervals import RunDraws
from libero_data.errors import MissingFileError, RunError


@dataclass
class RunSummary:
    """One run's numbers over its finished tasks."""

    path: Path
    config: dict[str, Any]
    results: RunResults
    tasks_done: int
    _draws: dict[str, RunDraws] = field(default_factory=dict, repr=False, compare=False)

    @property
    def group(self) -> tuple[str, str, str, tuple[str, ...]]:
        c = self.config
        return (c["algo"], c["policy"], c["preset"]["name"], tuple(t["name"] for t in c["tasks"]))

    @property
    def learned(self) -> list[str]:
        """Names of the finished tasks, in the order they were learned."""
        return [t["name"] for t in self.results.tasks][: self.tasks_done]

    @property
    def label(self) -> str:
        return f"{self.config['algo']} + {self.config['policy']}"

    def arrays(self, start: str = STORED) -> tuple[np.ndarray, np.ndarray]:
        k = self.tasks_done
        curve = np.asarray(self.results.curve_of(start), dtype=np.float64)[:k]
        after = np.asarray(self.results.after_of(start), dtype=np.float64)[:k, :k]
        return curve, after

    def draws(self, start: str) -> RunDraws:
        """The run's bootstrap draws from one kind of start (drawn once)."""
        if start not in self._draws:
            self._draws[start] = RunDraws(self.results, self.tasks_done, start)
        return self._draws[start]

    def has(self, start: str) -> bool:
        return any(r.get("start", STORED) == start for r in self.results.rollouts)

    def matrix(self, start: str = STORED) -> np.ndarray:
        """``M[tau, k]``: success on task k after learning task tau (diagonal: the kept
        checkpoint's while learning it); NaN above the diagonal."""
        _, after = self.arrays(start)
        m = np.full(after.shape, np.nan)
        for tau in range(after.shape[0]):
            m[tau, :tau] = after[tau, :tau]
            m[tau, tau] = self.results.kept_success(tau, start)
        return m

    def notes(self) -> list[str]:
        """What a reader must know about the run's evaluation starts."""
        starts = self.config.get("evaluation", {}).get("training_starts")
        if starts is None:
            return [f"{self.path.name}: the run does not record where its training data started"]
        out = []
        for name, s in starts.items():
            if not s.get("recorded", False):
                out.append(
                    f"{self.path.name}: the dataset does not record where the demonstrations of {name} started"
                )
            elif s.get("stored_eval_starts_trained_on"):
                n = len(s["stored_eval_starts_trained_on"])
                out.append(
                    f"{self.path.name}: the training data of {name} began from {n} of the stored init states its "
                    "evaluation starts from; its stored-start success measures starts the policy was trained on "
                    "(the held-out starts did not occur in training)"
                )
        return out


def load_run(path: str | Path) -> RunSummary:
    """Read a run folder; :class:`RunError` when it is not one or has no finished task."""
    folder = RunFolder(Path(path))
    if not folder.root.is_dir():
        raise MissingFileError(f"run folder {folder.root} does not exist")
    config = folder.read_config()
    results = folder.read_results()
    done = results.finished_tasks
    if done == 0:
        raise RunError(f"run {folder.root} has not finished its first task yet")
    return RunSummary(folder.root, config, results, done)
