"""Files that appear whole or not at all, and journals that survive a kill.

Every file a long job writes goes through here: written under a scratch name, flushed to disk,
then renamed into place. A process killed at any moment (even by SIGKILL) leaves either the old
file or the new one, plus at worst a scratch file that :meth:`WorkFolder.clean
<libero_data.runtime.folder.WorkFolder.clean>` removes on the next run.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np


def cache_root(explicit: str | Path | None = None) -> Path:
    """Where this project keeps what it can make again (simplified meshes, LIBERO-Plus's tasks): ``explicit``, ``$LIBERO_DATA_CACHE``, or the user's cache."""
    if explicit:
        return Path(explicit)
    if os.environ.get("LIBERO_DATA_CACHE"):
        return Path(os.environ["LIBERO_DATA_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "libero-data"


def write_bytes(path: Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (scratch file, fsync, rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with tmp.open("wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)  # a full disk leaves no half-written file behind
        raise
    return path


def read_json(path: Path, *, required: tuple[str, ...] = ()) -> Any:
    """A JSON file's content, with one sentence naming the file if it is missing, not JSON, or
    (``required``) not an object holding those fields."""
    from libero_data.errors import FileFormatError, MissingFileError

    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise MissingFileError(f"{path} is missing") from None
    except UnicodeDecodeError:
        raise FileFormatError(f"{path} is not valid JSON (not even text)") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileFormatError(
            f"{path} is not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
    if required:
        require_fields(data, required, path)
    return data


def require_fields(data: Any, fields: tuple[str, ...], path: Path) -> None:
    """One sentence naming ``path`` unless ``data`` (read from it) is an object with ``fields``."""
    from libero_data.errors import FileFormatError

    if not isinstance(data, dict):
        raise FileFormatError(f"{path} holds a JSON {type(data).__name__}, not an object")
    missing = [k for k in fields if k not in data]
    if missing:
        raise FileFormatError(f"{path} has no {', '.join(repr(k) for k in missing)} field")


def read_json_lines(path: Path) -> list[Any]:
    """The records of a JSON-lines file; one sentence naming the file and line of a bad one."""
    from libero_data.errors import FileFormatError

    rows = []
    for number, line in enumerate(Path(path).read_text().splitlines(), 1):
        if line.strip():
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError as exc:
                raise FileFormatError(f"{path}, line {number} is not valid JSON ({exc.msg})") from None
    return rows


def write_text(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically."""
    return write_bytes(path, text.encode())


def write_json(path: Path, data: Any, *, indent: int | None = 2, newline: bool = True) -> Path:
    """Write JSON (sorted keys) to ``path`` atomically."""
    return write_text(path, json.dumps(data, indent=indent, sort_keys=True) + ("\n" if newline else ""))


def save_npz(path: Path, **arrays: Any) -> Path:
    """Save arrays as ``.npz`` at ``path`` atomically."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # a name of its own per process: two processes storing the same entry (the mesh cache, built
    # by parallel workers) must not move each other's temporary file away
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp.npz")
    try:
        np.savez(tmp, **arrays)
        with tmp.open("rb") as f:
            os.fsync(f.fileno())
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)  # a full disk leaves no half-written file behind
        raise
    return path


def save_record(path: Path, record: dict[str, Any]) -> Path:
    """A record of arrays and JSON values as one ``.npz`` (arrays as themselves, the rest as JSON)."""
    payload: dict[str, Any] = {k: v for k, v in record.items() if isinstance(v, np.ndarray)}
    payload["meta"] = np.array(json.dumps({k: v for k, v in record.items() if not isinstance(v, np.ndarray)}))
    return save_npz(path, **payload)


def load_record(path: Path) -> dict[str, Any]:
    """Inverse of :func:`save_record`."""
    with np.load(path, allow_pickle=False) as data:
        record: dict[str, Any] = json.loads(str(data["meta"]))
        for key in data.files:
            if key != "meta":
                record[key] = data[key]
    return record


# -- folders ---------------------------------------------------------------------------------------
@contextlib.contextmanager
def atomic_folder(dest: Path) -> Iterator[Path]:
    """A scratch path next to ``dest`` (not created: the block makes it) that replaces ``dest``,
    flushed to disk, when the block ends.

    On an exception the scratch folder is removed and ``dest`` is left as it was.
    """
    tmp = scratch_folder(dest)
    try:
        yield tmp
        commit_folder(tmp, dest)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def scratch_folder(dest: Path) -> Path:
    """The scratch path (not created) where ``dest`` is built by this process."""
    tmp = dest.with_name(f"{dest.name}.tmp-{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)  # a leftover of an earlier process with this pid
    return tmp


def commit_folder(tmp: Path, dest: Path) -> None:
    """Flush the finished scratch folder ``tmp`` to disk and rename it to ``dest`` (replacing it)."""
    fsync_tree(tmp)
    if dest.exists():
        shutil.rmtree(dest)
    tmp.rename(dest)


def fsync_tree(root: Path) -> None:
    """Flush a freshly written folder to disk before it is renamed into place."""
    for path in sorted(root.rglob("*")):
        if path.is_file():
            fd = os.open(path, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)


def pack(path: Path) -> bytes | dict[str, bytes]:
    """A file's bytes, or every file under a folder as {relative path: bytes}: what a job on
    another machine sends back (see :func:`unpack`)."""
    if path.is_dir():
        return {str(f.relative_to(path)): f.read_bytes() for f in sorted(path.rglob("*")) if f.is_file()}
    return path.read_bytes()


def unpack(packed: bytes | dict[str, bytes], dest: Path) -> Path:
    """Write what :func:`pack` made at ``dest``, which appears (or is replaced) atomically."""
    dest = Path(dest)
    if isinstance(packed, bytes):
        return write_bytes(dest, packed)
    dest.parent.mkdir(parents=True, exist_ok=True)
    with atomic_folder(dest) as tmp:
        tmp.mkdir(parents=True)
        for rel, data in packed.items():
            (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp / rel).write_bytes(data)
    return dest


# -- journals --------------------------------------------------------------------------------------
class Journal:
    """A JSON-lines file written one synced line at a time: an optional header, then entries.

    A line cut by a kill is dropped when the journal is read (its entry is simply redone), and
    removed from the file so the next line starts on its own.
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)

    def exists(self) -> bool:
        return self.path.is_file()

    def start(self, header: Any) -> None:
        """Begin a new journal (replacing any) with ``header`` as its first line."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._write([header], mode="w")

    def append(self, entry: Any) -> None:
        self._write([entry], mode="a")

    def read(self) -> list[Any]:
        """Every whole line, parsed (the header first, where there is one)."""
        text = self.path.read_text()
        if text and not text.endswith("\n"):  # drop the cut line so the next one starts on its own
            text = text[: text.rfind("\n") + 1]
            self.path.write_text(text)
        out = []
        for line in text.splitlines():
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError:
                continue  # a damaged line: its entry is redone
        return out

    def _write(self, entries: list[Any], mode: str) -> None:
        with self.path.open(mode) as f:
            for entry in entries:
                f.write(json.dumps(entry) + "\n")
            f.flush()
            os.fsync(f.fileno())
