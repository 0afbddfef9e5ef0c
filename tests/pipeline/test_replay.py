"""replay: a stored episode as a Rerun recording, read back with rerun's dataframe API."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.pipeline.conftest import run_cli

pytestmark = pytest.mark.sim


def test_replay_writes_a_readable_recording(tiny_dataset: Path, tmp_path: Path) -> None:
    import rerun.recording as rd

    out = tmp_path / "ep1.rrd"
    result = run_cli("replay", str(tiny_dataset), "--episode", "1", "--rrd", str(out))
    assert result.returncode == 0, result.stderr
    length = json.loads((tiny_dataset / "meta" / "libero_episodes.jsonl").read_text().splitlines()[1])[
        "length"
    ]
    recording = rd.load_recording(str(out))
    table = recording.view(index="frame", contents="/**").select().read_all()
    columns = set(table.column_names)
    for needed in (
        "/cameras/agentview:EncodedImage:blob",
        "/cameras/eye_in_hand:EncodedImage:blob",
        "/action/gripper:Scalars:scalars",
        "/state/eef_z:Scalars:scalars",
    ):
        assert needed in columns, sorted(columns)
    frames = table.column("frame").to_pylist()
    assert len(frames) == length and frames[0] == 0 and frames[-1] == length - 1
    language = recording.view(index="frame", contents="/language").select_static().read_all()
    assert "turn on the stove" in str(language.to_pylist())


def test_replay_unknown_episode(tiny_dataset: Path, tmp_path: Path) -> None:
    result = run_cli("replay", str(tiny_dataset), "--episode", "7", "--rrd", str(tmp_path / "x.rrd"))
    assert result.returncode == 2
    assert "has episodes 0..1, not 7" in result.stderr
