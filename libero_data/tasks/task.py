"""A task and a suite: what every source of tasks (LIBERO's suites, LIBERO-PRO's, LIBERO-Plus's,
suite folders) makes."""

from __future__ import annotations

import difflib
import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from libero_data.errors import MissingFileError, TaskLookupError
from libero_data.runtime.files import read_json

if TYPE_CHECKING:
    import numpy as np

    from libero_data.bddl import Problem


@dataclass(frozen=True)
class Task:
    """One task: where it sits in its suite, its instruction, BDDL and init states.

    ``language`` is the instruction LIBERO's benchmark gives policies (derived from the task
    name; for LIBERO-PRO's paraphrase and new-task suites, the BDDL's own sentence);
    ``problem.language`` is the sentence written inside the BDDL file. ``missing`` says, in one
    sentence, what a task needs that is not here (a LIBERO-Plus task's asset); empty when it can
    be built.
    """

    suite: str
    index: int
    name: str
    language: str
    bddl_path: Path
    init_states_path: Path | None = field(default=None, compare=False)
    missing: str = field(default="", compare=False)

    @property
    def id(self) -> str:
        return f"{self.suite}/{self.index}"

    def require_buildable(self) -> None:
        """Raise :class:`MissingFileError` with :attr:`missing` when the task cannot be built."""
        if self.missing:
            raise MissingFileError(self.missing)

    @functools.cached_property
    def problem(self) -> Problem:
        from libero_data.bddl import parse_file

        return parse_file(self.bddl_path)

    @property
    def goal_text(self) -> str:
        from libero_data.bddl import formula_text

        return formula_text(self.problem.goal)

    def init_states(self) -> np.ndarray:
        """The stored init states (flattened MuJoCo states), shape ``(n, state_dim)``."""
        import numpy as np

        if self.init_states_path is None or not self.init_states_path.is_file():
            raise MissingFileError(f"task {self.id} has no stored init states")
        with np.load(self.init_states_path, allow_pickle=False) as data:
            return np.asarray(data["states"], dtype=np.float64)


#: A suite folder's manifest: its tasks in order, and the generator's settings where one made it.
SUITE_MANIFEST = "suite.json"
#: What a generated suite folder holds besides a dataset (which may share the folder).
SUITE_FILES = (SUITE_MANIFEST, "tasks", "procedural_report.json", "procedural_report.md")


@dataclass(frozen=True)
class Suite:
    name: str
    tasks: tuple[Task, ...]
    path: Path | None = None  # set for suites read from a folder

    def manifest(self) -> dict[str, Any]:
        """The suite folder's manifest (empty for the shipped suites and bare BDDL folders)."""
        if self.path is None or not (self.path / SUITE_MANIFEST).is_file():
            return {}
        return dict(read_json(self.path / SUITE_MANIFEST, required=("tasks",)))

    def __len__(self) -> int:
        return len(self.tasks)

    def task(self, key: int | str) -> Task:
        """A task by index or by name."""
        if isinstance(key, int) or (isinstance(key, str) and key.lstrip("-").isdigit()):
            i = int(key)
            if not 0 <= i < len(self.tasks):
                raise TaskLookupError(f"suite {self.name} has tasks 0..{len(self.tasks) - 1}, not {i}")
            return self.tasks[i]
        for task in self.tasks:
            if task.name == key:
                return task
        raise TaskLookupError(
            unknown(f"task {key!r} in suite {self.name}", key, [t.name for t in self.tasks])
        )


def unknown(what: str, key: str, candidates: list[str]) -> str:
    close = difflib.get_close_matches(key, candidates, n=3, cutoff=0.4)
    hint = f"; closest: {', '.join(close)}" if close else ""
    return f"unknown {what}{hint}"


def language_from_name(name: str) -> str:
    """LIBERO's rule: drop the ``SCENE<n>_`` prefix of libero_90/10 names, words by '_'."""
    if name[:1].isupper() and "SCENE" in name:
        rest = name[name.index("SCENE") + len("SCENE") :]
        rest = rest.lstrip("0123456789")
        name = rest.lstrip("_")
    return " ".join(name.split("_"))
