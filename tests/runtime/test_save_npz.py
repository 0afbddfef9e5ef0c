"""``save_npz`` writes atomically, and two processes saving one file never share a temporary
(the mesh cache is filled by parallel workers: a shared temporary name let one worker move the
other's file away, and its rename then failed)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from libero_data.runtime.files import save_npz


def test_two_writers_of_one_file_use_temporaries_of_their_own(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    written: list[str] = []
    savez = np.savez

    def spy(file: Path, **arrays: Any) -> None:
        written.append(Path(file).name)
        savez(file, **arrays)

    monkeypatch.setattr(np, "savez", spy)
    for pid, value in ((101, 1), (202, 2)):
        monkeypatch.setattr(os, "getpid", lambda pid=pid: pid)
        save_npz(tmp_path / "entry.npz", faces=np.full(3, value))
    assert len(set(written)) == 2 and all(name.endswith(".tmp.npz") for name in written)
    with np.load(tmp_path / "entry.npz") as data:
        assert data["faces"].tolist() == [2, 2, 2]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["entry.npz"]  # no temporary left
