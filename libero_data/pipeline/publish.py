"""Publishing a dataset snapshot into the output folder without ever leaving it broken.

A snapshot is built completely in the work area, then each top-level entry of the output
folder (``videos``, ``mcap``, ``data``, ``meta``, ``README.md``) is swapped with its new
version. On Linux the swap is ``renameat2(RENAME_EXCHANGE)``: the entry is replaced in one
step and never missing. A journal names the snapshot being published; every new entry
carries the snapshot's id, so an interrupted publish is finished, not repeated, by
:func:`recover`.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import json
import os
import shutil
from pathlib import Path

from libero_data.runtime.files import write_json

ENTRIES = ("videos", "mcap", "data", "meta", "README.md")
STAMP = ".libero-data-snapshot"
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Atomically swap two paths; False where the system cannot."""
    libc_name = ctypes.util.find_library("c")
    if not libc_name:
        return False
    libc = ctypes.CDLL(libc_name, use_errno=True)
    func = getattr(libc, "renameat2", None)
    if func is None:
        return False
    func.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    rc = func(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(a))


def stamp_of(entry: Path) -> str | None:
    """The snapshot id recorded in an entry (a folder's stamp file, or README.md's last line)."""
    try:
        if entry.is_dir():
            return (entry / STAMP).read_text().strip()
        if entry.is_file():
            last = entry.read_text().rstrip().rsplit("\n", 1)[-1]
            if last.startswith("<!-- libero-data snapshot ") and last.endswith(" -->"):
                return last[len("<!-- libero-data snapshot ") : -len(" -->")]
    except (OSError, UnicodeDecodeError):
        return None
    return None


def stamp(snapshot: Path, snapshot_id: str) -> None:
    """Mark every entry of a freshly built snapshot with its id."""
    for name in ENTRIES:
        entry = snapshot / name
        if entry.is_dir():
            (entry / STAMP).write_text(snapshot_id + "\n")
        elif entry.is_file():
            text = entry.read_text().rstrip("\n")
            entry.write_text(f"{text}\n\n<!-- libero-data snapshot {snapshot_id} -->\n")


def unstamp(dataset: Path) -> None:
    """Remove the stamps from a finished dataset's folders: they only matter while it grows, and a
    published or uploaded dataset should not carry hidden files."""
    for entry in sorted(dataset.glob(f"*/{STAMP}")):
        entry.unlink(missing_ok=True)


def publish(snapshot: Path, dest: Path, journal: Path) -> None:
    """Move the entries of ``snapshot`` into ``dest`` (same file system), replacing old ones."""
    snapshot_id = stamp_of(snapshot / "meta")
    if snapshot_id is None:
        raise ValueError(f"{snapshot} is not a stamped snapshot")
    write_json(journal, {"snapshot": str(snapshot), "id": snapshot_id}, indent=None, newline=False)
    _finish(snapshot, dest, snapshot_id)
    journal.unlink()


def recover(dest: Path, journal: Path) -> bool:
    """Finish a publish that was interrupted; True if there was one."""
    if not journal.is_file():
        return False
    record = json.loads(journal.read_text())
    _finish(Path(record["snapshot"]), dest, record["id"])
    journal.unlink()
    return True


def _finish(snapshot: Path, dest: Path, snapshot_id: str) -> None:
    for name in ENTRIES:
        new, old = snapshot / name, dest / name
        if stamp_of(old) == snapshot_id:
            continue  # already in place
        if not new.exists():
            continue
        if old.exists() and _exchange(new, old):
            continue
        if old.exists():
            aside = snapshot / f"{name}.old"
            if aside.exists():
                _remove(aside)
            old.rename(aside)
        new.rename(old)
    _remove(snapshot)


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    elif path.exists() or path.is_symlink():
        path.unlink()
