"""The work folder of a resumable job: one writer at a time, the settings it was started with,
and clean-up of what an interrupted run left half-written.

A long command (``generate``, ``expert-report``, a procedural suite, a benchmark run) keeps
its state in a folder. Running the same command again continues it; running another command
on it is refused with the settings that differ, instead of mixing two jobs' results.
"""

from __future__ import annotations

import contextlib
import fcntl
import shutil
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from libero_data.errors import FolderBusy, FolderError, SettingsChanged
from libero_data.runtime.files import read_json, write_json

#: The hidden work folder inside a dataset folder (``libero-data``'s state while it generates).
DATASET_WORK = ".libero-data"


def changed_keys(saved: Mapping[str, Any], now: Mapping[str, Any], ignore: Iterable[str] = ()) -> list[str]:
    """The top-level keys whose values differ (sorted), leaving out ``ignore``."""
    skip = set(ignore)
    return sorted(k for k in set(saved) | set(now) if k not in skip and saved.get(k) != now.get(k))


class WorkFolder:
    """A folder holding one resumable job's state; ``what`` names the job in messages."""

    def __init__(self, root: Path, what: str) -> None:
        self.root = Path(root)
        self.what = what

    def path(self, *parts: str) -> Path:
        return self.root.joinpath(*parts)

    def check_free(self, owner: Path | None = None) -> None:
        """:class:`FolderBusy` now if another process holds the lock (nothing is created)."""
        lock = self.root / "lock"
        if not lock.is_file():
            return
        with lock.open("r") as handle:
            self._take(handle, owner)
            fcntl.flock(handle, fcntl.LOCK_UN)

    def _take(self, handle: Any, owner: Path | None) -> None:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderBusy(f"another process is writing the {self.what} in {owner or self.root}") from None

    @contextlib.contextmanager
    def locked(self, owner: Path | None = None) -> Iterator[None]:
        """Hold the folder's lock for the block; :class:`FolderBusy` if another process has it."""
        self.root.mkdir(parents=True, exist_ok=True)
        with (self.root / "lock").open("w") as handle:
            self._take(handle, owner)
            try:
                yield
            finally:
                fcntl.flock(handle, fcntl.LOCK_UN)

    def claim(
        self,
        settings: Mapping[str, Any],
        *,
        name: str = "settings.json",
        ignore: Iterable[str] = (),
        owner: Path | None = None,
        advice: str = "use the same command to continue it, or another output folder",
        legacy: Mapping[str, Any] | None = None,
        record: bool = True,
        upgrade: Callable[[Mapping[str, Any]], dict[str, Any]] | None = None,
    ) -> dict[str, Any] | None:
        """Record ``settings`` as the folder's, or check them against those recorded
        (``record=False``: check only, write nothing).

        Returns the recorded settings (None on first use). Raises :class:`SettingsChanged`
        naming the keys that differ (``ignore`` lists keys that may change between runs;
        ``legacy`` gives the value of a key that folders made before it existed implied;
        ``upgrade``, where given, reads both the recorded and the asked settings as the current
        version does: a config's own :meth:`~libero_data.config.Config.upgrade`).
        """
        path = self.root / name
        if not path.is_file():
            if record:
                write_json(path, dict(settings), newline=False)
            return None
        recorded = read_json(path)
        if not isinstance(recorded, dict):
            raise FolderError(f"{path} is not a settings file of libero-data or libero-bench")
        saved = upgrade(recorded) if upgrade else {**(legacy or {}), **recorded}
        asked = upgrade(settings) if upgrade else settings
        changed = changed_keys(saved, asked, ignore)
        if changed:
            values = [
                f"{k} {saved.get(k)!r} there, {asked.get(k)!r} asked"
                for k in changed
                if isinstance(saved.get(k), (int, float, str)) and isinstance(asked.get(k), (int, float, str))
            ]
            raise SettingsChanged(
                f"{owner or self.root} holds a {self.what} made with different settings "
                f"({', '.join(changed)}){''.join(f'; {v}' for v in values)}; {advice}",
                changed=changed,
            )
        return dict(saved)

    def clean(self, *patterns: str) -> None:
        """Remove what matches ``patterns`` (glob, relative to the folder): scratch files and
        folders an interrupted run left behind."""
        for pattern in patterns:
            for path in self.root.glob(pattern):
                if path.is_dir() and not path.is_symlink():
                    shutil.rmtree(path, ignore_errors=True)
                else:
                    path.unlink(missing_ok=True)
