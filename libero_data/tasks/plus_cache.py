"""LIBERO-Plus's tasks written once into a cache folder, as files LIBERO and this project read:
``bddl/<suite>/<task>.bddl`` (their BDDL, our perturbation comment first), ``init/<suite>/<file>.npz``
(their init states as NumPy arrays) and ``<suite>.json`` (what each task is), all under
``<cache>/plus/<digest of their files>/``. A suite already written is read back from its JSON."""

from __future__ import annotations

import functools
import json
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from libero_data.bddl.parser import PERTURBATION_MARK
from libero_data.errors import FileFormatError, TaskLookupError
from libero_data.tasks.plus import (
    BASES,
    PREFIX,
    PlusName,
    PlusTaskInfo,
    parse_name,
    plus_base,
    plus_files,
    their_prompt,
)
from libero_data.tasks.task import Suite, Task, language_from_name

if TYPE_CHECKING:
    from libero_data.tasks.plus_files import PlusFiles

#: The cache's format: a change of what is written makes a new folder's content.
FORMAT = 1
_PROBLEM = re.compile(r"\(define\s+\(problem\s+([^\s)]+)\s*\)")
_LANGUAGE = re.compile(r"\(:language\s+([^)]*)\)")


def materialize(
    files: PlusFiles, folder: Path, suite: str, base: str, names: list[str]
) -> tuple[list[Task], list[PlusTaskInfo]]:
    """The tasks of ``suite`` (their ``names`` in order), written under ``folder`` where missing."""
    index = folder / f"{base}.json"
    if index.is_file():
        try:
            saved = json.loads(index.read_text())
        except json.JSONDecodeError:
            saved = {}
        if saved.get("format") == FORMAT and saved.get("names") == names:
            return _read_back(folder, suite, base, saved["tasks"])
    tasks: list[Task] = []
    infos: list[PlusTaskInfo] = []
    rows: list[dict[str, Any]] = []
    written_inits: set[str] = set()
    for i, name in enumerate(names):
        parsed = parse_name(name)
        rel = f"bddl_files/{base}/{parsed.bddl_name}"
        text = files.read(rel).decode()
        problem = _PROBLEM.search(text)
        sentence = _LANGUAGE.search(text)
        if problem is None or sentence is None:
            raise FileFormatError(f"LIBERO-Plus: {files.where(rel)} names no problem or no language")
        robot_start = files.robot_starts.get(parsed.robot) if parsed.robot else None
        if parsed.robot and robot_start is None:
            raise FileFormatError(
                f"LIBERO-Plus: task {name} starts the arm from pose {parsed.robot}, not defined"
            )
        language = " ".join(sentence.group(1).split()) if parsed.language else language_from_name(parsed.base)
        prompt = language if parsed.language else their_prompt(name)
        bddl = folder / "bddl" / base / f"{name}.bddl"
        if not bddl.is_file():
            comment = json.dumps(parsed.perturbation(robot_start), sort_keys=True, separators=(",", ":"))
            _write(bddl, f"{PERTURBATION_MARK} {comment}\n{text}".encode())
        init_rel = parsed.init_file(base)
        init = folder / "init" / Path(init_rel).relative_to("init_files").with_suffix(".npz")
        if init_rel not in written_inits and not init.is_file():
            _save_states(init, files.init_states(init_rel))
        written_inits.add(init_rel)
        info = PlusTaskInfo(suite, i, parsed, language, prompt, problem.group(1))
        tasks.append(Task(suite, i, name, language, bddl, init))
        infos.append(info)
        rows.append(_row(info, bddl, init, folder))
    _write(index, json.dumps({"format": FORMAT, "names": names, "tasks": rows}).encode())
    return tasks, infos


def _row(info: PlusTaskInfo, bddl: Path, init: Path, folder: Path) -> dict[str, Any]:
    p = info.parsed
    return {
        "name": p.name,
        "base": p.base,
        "category": p.category,
        "view": list(p.view),
        "robot": p.robot,
        "noise": p.noise,
        "language_variant": p.language,
        "variant": p.variant,
        "language": info.language,
        "their_prompt": info.their_prompt,
        "problem_class": info.problem_class,
        "bddl": bddl.relative_to(folder).as_posix(),
        "init": init.relative_to(folder).as_posix(),
    }


def _read_back(
    folder: Path, suite: str, base: str, rows: list[dict[str, Any]]
) -> tuple[list[Task], list[PlusTaskInfo]]:
    tasks, infos = [], []
    for i, row in enumerate(rows):
        parsed = PlusName(
            row["name"],
            row["base"],
            row["category"],
            tuple(row["view"]),
            int(row["robot"]),
            int(row["noise"]),
            int(row["language_variant"]),
            row["variant"],
        )
        tasks.append(Task(suite, i, row["name"], row["language"], folder / row["bddl"], folder / row["init"]))
        infos.append(
            PlusTaskInfo(suite, i, parsed, row["language"], row["their_prompt"], row["problem_class"])
        )
    return tasks, infos


def _write(path: Path, data: bytes) -> None:
    """A cache file written whole or not at all (a name of its own per process while writing)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def _save_states(path: Path, states: Any) -> None:
    import io

    import numpy as np

    buffer = io.BytesIO()
    np.savez(buffer, states=np.asarray(states, dtype=np.float64))
    _write(path, buffer.getvalue())


def plus_suite(name: str, source: str | Path | None = None) -> Suite:
    """The LIBERO-Plus suite ``plus/<base>``: every task of theirs, in their order."""
    return _plus_suite(name, plus_files(source))


def plus_infos(name: str, source: str | Path | None = None) -> tuple[PlusTaskInfo, ...]:
    """What their data says of each task of ``plus/<base>`` (category, parameters, prompts), in
    the suite's order."""
    return _catalogue(name, plus_files(source))[1]


def _plus_suite(name: str, files: PlusFiles) -> Suite:
    return _catalogue(name, files)[0]


@functools.cache
def _catalogue(name: str, files: PlusFiles) -> tuple[Suite, tuple[PlusTaskInfo, ...]]:
    from libero_data.runtime.files import cache_root

    base = plus_base(name)
    if base is None:
        raise TaskLookupError(
            f"unknown LIBERO-Plus suite {name!r}; known: {', '.join(PREFIX + b for b in BASES)}"
        )
    names = files.task_map.get(base)
    if not names:
        raise FileFormatError(f"LIBERO-Plus: {files.where('benchmark')} lists no tasks of {base}")
    tasks, infos = materialize(files, cache_root() / "plus" / files.digest, name, base, names)
    return Suite(name, tuple(tasks)), tuple(infos)
