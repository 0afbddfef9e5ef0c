"""Work folders (one writer, recorded settings, clean-up) and files that appear whole."""

from __future__ import annotations

import json
import multiprocessing as mp
from pathlib import Path

import numpy as np
import pytest

from libero_data.errors import FolderBusy, SettingsChanged
from libero_data.runtime.files import Journal, load_record, pack, save_record, unpack, write_json
from libero_data.runtime.folder import WorkFolder, changed_keys


def test_claim_records_settings_and_names_what_changed(tmp_path: Path) -> None:
    folder = WorkFolder(tmp_path / "w", "dataset")
    assert folder.claim({"seed": 0, "tasks": [1, 2], "runtime": "a"}) is None
    assert folder.claim({"seed": 0, "tasks": [1, 2], "runtime": "b"}, ignore=("runtime",)) is not None
    with pytest.raises(SettingsChanged, match=r"different settings \(seed, tasks\)") as error:
        folder.claim({"seed": 1, "tasks": [1], "runtime": "a"})
    assert error.value.changed == ["seed", "tasks"]
    assert changed_keys({"a": 1}, {"b": 2}) == ["a", "b"]


def _hold(path: str, ready: object, release: object) -> None:
    with WorkFolder(Path(path), "dataset").locked():
        ready.set()  # type: ignore[attr-defined]
        release.wait(10)  # type: ignore[attr-defined]


def test_a_second_writer_is_refused(tmp_path: Path) -> None:
    ctx = mp.get_context("spawn")
    ready, release = ctx.Event(), ctx.Event()
    holder = ctx.Process(target=_hold, args=(str(tmp_path), ready, release))
    holder.start()
    try:
        assert ready.wait(60)
        with pytest.raises(FolderBusy, match="another process"), WorkFolder(tmp_path, "dataset").locked():
            pass
    finally:
        release.set()
        holder.join(30)
    with WorkFolder(tmp_path, "dataset").locked():  # free again
        pass


def test_clean_removes_what_an_interrupted_run_left(tmp_path: Path) -> None:
    folder = WorkFolder(tmp_path, "dataset")
    (tmp_path / "shards" / "000-00000.tmp-12").mkdir(parents=True)
    (tmp_path / "shards" / "000-00001").mkdir()
    (tmp_path / "search").mkdir()
    (tmp_path / "search" / "a.npz.tmp.npz").write_text("x")
    folder.clean("shards/*.tmp-*", "search/*.tmp.npz")
    assert [p.name for p in (tmp_path / "shards").iterdir()] == ["000-00001"]
    assert list((tmp_path / "search").iterdir()) == []


def test_files_records_and_packed_folders_round_trip(tmp_path: Path) -> None:
    write_json(tmp_path / "a" / "x.json", {"b": 1, "a": [1, 2]})
    assert json.loads((tmp_path / "a" / "x.json").read_text()) == {"a": [1, 2], "b": 1}
    assert not list(tmp_path.glob("a/*.tmp"))
    states = np.arange(6.0).reshape(2, 3)
    save_record(tmp_path / "r.npz", {"success": True, "attempts": 2, "states": states})
    back = load_record(tmp_path / "r.npz")
    assert back["attempts"] == 2 and np.array_equal(back["states"], states)
    (tmp_path / "tree" / "sub").mkdir(parents=True)
    (tmp_path / "tree" / "sub" / "f.bin").write_bytes(b"123")
    unpack(pack(tmp_path / "tree"), tmp_path / "copy")
    assert (tmp_path / "copy" / "sub" / "f.bin").read_bytes() == b"123"
    unpack(pack(tmp_path / "r.npz"), tmp_path / "r2.npz")
    assert (tmp_path / "r2.npz").read_bytes() == (tmp_path / "r.npz").read_bytes()


def test_a_journal_drops_a_line_cut_by_a_kill(tmp_path: Path) -> None:
    journal = Journal(tmp_path / "j.jsonl")
    journal.start({"settings": 1})
    journal.append({"ref": "a"})
    with journal.path.open("a") as f:
        f.write('{"ref": "b", "x')
    assert journal.read() == [{"settings": 1}, {"ref": "a"}]
    journal.append({"ref": "c"})
    assert journal.read() == [{"settings": 1}, {"ref": "a"}, {"ref": "c"}]
