"""validate: a good dataset passes (re-simulation included); each kind of damage is caught."""

from __future__ import annotations

import shutil
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from libero_data.pipeline.validate import validate
from tests.pipeline.conftest import run_cli

pytestmark = pytest.mark.sim


@pytest.fixture
def damaged(tiny_dataset: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "copy"
    shutil.copytree(tiny_dataset, copy, ignore=shutil.ignore_patterns(".libero-data"))
    return copy


def test_a_good_dataset_validates_and_resimulates(tiny_dataset: Path) -> None:
    result = run_cli("validate", str(tiny_dataset), "--resimulate", "2")
    assert result.returncode == 0, result.stderr
    assert "re-simulated 2 episode(s): 2 reached their goal" in result.stdout
    assert "ok: no inconsistency found" in result.stdout


def test_truncated_parquet(damaged: Path) -> None:
    path = damaged / "data" / "chunk-000" / "file-001.parquet"
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    report = validate(damaged)
    assert any("unreadable parquet" in str(i) and "file-001.parquet" in str(i) for i in report.issues or [])
    result = run_cli("validate", str(damaged))
    assert result.returncode == 1
    assert "problem: data/chunk-000/file-001.parquet: unreadable parquet" in result.stderr
    assert "Traceback" not in result.stderr


def test_missing_video(damaged: Path) -> None:
    (damaged / "videos" / "observation.images.wrist_image" / "chunk-000" / "file-000.mp4").unlink()
    issues = [str(i) for i in validate(damaged).issues or []]
    assert issues == [
        "videos/observation.images.wrist_image/chunk-000/file-000.mp4: missing video (episode 0, observation.images.wrist_image)"
    ]


def test_wrong_frame_count(damaged: Path) -> None:
    path = next((damaged / "meta" / "episodes").glob("*/*.parquet"))
    table = pq.read_table(path)
    lengths = table.column("length").to_pylist()
    lengths[1] += 3
    table = table.set_column(
        table.column_names.index("length"),
        "length",
        pa.array(lengths, type=table.schema.field("length").type),
    )
    pq.write_table(table, path)
    issues = [str(i) for i in validate(damaged).issues or []]
    assert any("total_frames" in i for i in issues)
    assert any(f"episode 1 has {lengths[1] - 3} rows but its length is {lengths[1]}" in i for i in issues)
    assert any("video frames" in i and "episode 1" in i for i in issues)


def test_not_a_dataset(tmp_path: Path) -> None:
    result = run_cli("validate", str(tmp_path))
    assert result.returncode == 1
    assert "not a LeRobot dataset (meta/info.json is missing)" in result.stderr
