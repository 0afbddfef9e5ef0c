"""A full disk at any writer of an episode (its videos, Parquet, MCAP log, the search record) is
the system's own error, raised where the command can turn it into one sentence; no background
thread prints a traceback, and no half-written file is left. The failure is injected at each
writer (OSError with the system's errno), which any machine can do."""

from __future__ import annotations

import errno
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from libero_data.cli.common import system_failure

FULL = "No space left on device"


def _frames(n: int = 6, size: int = 32) -> list[dict[str, Any]]:
    rng = np.random.default_rng(0)
    return [
        {
            "agentview": rng.integers(0, 255, (size, size, 3), dtype=np.uint8),
            "eye_in_hand": rng.integers(0, 255, (size, size, 3), dtype=np.uint8),
            "state": np.zeros(8, np.float32),
            "joint_pos": np.zeros(7, np.float32),
            "gripper_state": np.zeros(2, np.float32),
            "eef_pos": np.zeros(3),
            "eef_quat": np.array([0.0, 0.0, 0.0, 1.0]),
            "sim_state": np.zeros(20),
            "action": np.zeros(7, np.float32),
        }
        for _ in range(n)
    ]


def _full(path: object = None) -> OSError:
    return OSError(errno.ENOSPC, FULL, str(path) if path is not None else None)


def _video(monkeypatch: pytest.MonkeyPatch) -> None:
    import av

    real_open = av.open

    class Filling:
        """A container whose writes fail as PyAV's do on a full disk (the close too)."""

        def __init__(self, path: str, *args: Any, **kwargs: Any) -> None:
            self.inner, self.path = real_open(path, *args, **kwargs), path

        def __getattr__(self, name: str) -> Any:
            return getattr(self.inner, name)

        def mux(self, packets: Any) -> None:
            raise _full(self.path)

        def close(self) -> None:
            self.inner.close()
            raise _full(self.path)

    monkeypatch.setattr(
        av,
        "open",
        lambda path, mode="r", *a, **k: (
            Filling(path, mode, *a, **k) if mode == "w" else real_open(path, mode, *a, **k)
        ),
    )


def _parquet(monkeypatch: pytest.MonkeyPatch) -> None:
    import pyarrow.parquet as pq

    def fails(self: Any, table: Any, *args: Any, **kwargs: Any) -> None:
        raise OSError(f"Error writing bytes to file. Detail: [errno {errno.ENOSPC}] {FULL}")  # pyarrow's

    monkeypatch.setattr(pq.ParquetWriter, "write_table", fails)


def _mcap(monkeypatch: pytest.MonkeyPatch) -> None:
    from libero_data.record import shard

    def fails(path: Path, **kwargs: Any) -> None:
        raise _full(path)

    monkeypatch.setattr(shard, "write_episode_mcap", fails)


@pytest.mark.parametrize("writer", [_video, _parquet, _mcap], ids=["video", "parquet", "mcap"])
def test_a_full_disk_while_writing_an_episode_is_the_systems_error_alone(
    writer: Any, monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from libero_data.record.features import FeatureLayout
    from libero_data.record.shard import write_frames

    writer(monkeypatch)
    with pytest.raises(OSError) as failed:
        write_frames(
            tmp_path / "shard",
            frames=_frames(),
            success=[False] * 6,
            task="t",
            instruction="do it",
            layout=FeatureLayout(image_size=32),
            sim_state_width=20,
            info={"key": "k"},
        )
    sentence = system_failure(failed.value, where=str(tmp_path))
    assert sentence is not None and sentence.startswith("no space left on the device while writing")
    assert "Traceback" not in capfd.readouterr().err  # no thread printed one
    assert list(tmp_path.iterdir()) == []  # no half-written shard or scratch folder


def test_a_full_disk_while_saving_a_search_record_leaves_no_file(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from libero_data.runtime import files

    def fails(fd: int) -> None:
        raise _full()

    monkeypatch.setattr(files.os, "fsync", fails)
    with pytest.raises(OSError) as failed:
        files.save_record(tmp_path / "search" / "k.npz", {"actions": np.zeros((3, 7)), "seed": 1})
    assert system_failure(failed.value, where=str(tmp_path)) is not None
    assert list((tmp_path / "search").iterdir()) == []
    with pytest.raises(OSError):
        files.write_bytes(tmp_path / "x.json", b"{}")
    assert list(tmp_path.glob("*.tmp")) == [] and not (tmp_path / "x.json").exists()
