"""validate: a good dataset passes (re-simulation included); each kind of damage is caught."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
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


def _shift_stored_state(root: Path, episode: int, frame: int, by: float) -> None:
    """Move one stored joint position of one frame (as a changed or foreign state would be)."""
    for path in sorted((root / "data").glob("*/*.parquet")):
        table = pq.read_table(path)
        rows = table.to_pydict()
        hits = [
            i
            for i, (e, f) in enumerate(zip(rows["episode_index"], rows["frame_index"], strict=True))
            if e == episode and f == frame
        ]
        if hits:
            from libero_data.record.features import SIM_STATE, sim_states

            states = sim_states([rows[SIM_STATE][hits[0]]])  # float64, bit for bit
            states[0, 1] += by  # qpos[0], the arm's first joint
            rows[SIM_STATE][hits[0]] = states.view(np.int64)[0].tolist()
            pq.write_table(pa.Table.from_pydict(rows, schema=table.schema), path)
            return
    raise AssertionError(f"no frame {frame} of episode {episode}")


def test_a_replay_on_another_machine_is_explained_and_judged_by_the_tolerance(tiny_dataset: Path) -> None:
    # A CPU without FMA, as glibc sees it: its libm takes the non-FMA variants of sin, cos, ...,
    # which MuJoCo calls, so the replay departs from the stored states in the last bits.
    from libero_data.numerics import cpu_flags, libm_uses_fma

    if not libm_uses_fma(cpu_flags()):
        pytest.skip("this CPU has no FMA variants to take away, so it cannot play another machine")
    other = {"GLIBC_TUNABLES": "glibc.cpu.hwcaps=-FMA"}
    strict = run_cli("validate", str(tiny_dataset), "--resimulate", "2", env=other)
    assert strict.returncode == 1, strict.stdout
    assert "re-simulated 2 episode(s): 2 reached their goal" in strict.stdout
    assert "departs from the stored states at frame" in strict.stderr
    assert "largest deviation of" in strict.stderr and "where an exact replay was asked for" in strict.stderr
    assert "(FMA variants) there" in strict.stderr and "(no FMA variants) here" in strict.stderr
    assert "--tolerance sets how far they may" in strict.stderr
    assert "Traceback" not in strict.stderr
    loose = run_cli("validate", str(tiny_dataset), "--resimulate", "2", "--tolerance", "1e-3", env=other)
    assert loose.returncode == 0, loose.stderr
    assert "within the tolerance of 0.001" in loose.stdout and "ok: no inconsistency found" in loose.stdout


def test_a_replay_on_the_machine_that_made_it_stays_exact_whatever_the_tolerance(damaged: Path) -> None:
    _shift_stored_state(damaged, episode=1, frame=12, by=1e-9)
    report = validate(damaged, resimulate=2, tolerance=1.0)
    issues = [str(i) for i in report.issues or []]
    assert len(issues) == 1, issues
    assert issues[0].startswith("episode 1: re-simulation departs from the stored states at frame 12")
    assert "this machine runs the numeric path that made it" in issues[0]
    assert report.departed_elsewhere == 0 and report.resimulated_ok == 2


def test_a_dataset_without_machines_gets_the_tolerance_and_says_so(damaged: Path) -> None:
    import json

    # As a dataset written before machines were recorded: no fingerprints, no keys.
    meta_path = damaged / "meta" / "libero.json"
    meta = json.loads(meta_path.read_text())
    del meta["machines"]
    meta_path.write_text(json.dumps(meta))
    rows_path = damaged / "meta" / "libero_episodes.jsonl"
    rows = [json.loads(line) for line in rows_path.read_text().splitlines()]
    rows_path.write_text(
        "".join(json.dumps({k: v for k, v in r.items() if k != "numeric_key"}) + "\n" for r in rows)
    )
    _shift_stored_state(damaged, episode=0, frame=30, by=2e-6)
    strict = validate(damaged, resimulate=2)
    assert [i.where for i in strict.issues or []] == ["episode 0"]
    assert "does not record the machine that made it" in str((strict.issues or [])[0])
    assert strict.departed_elsewhere == 1
    loose = validate(damaged, resimulate=2, tolerance=1e-5)
    assert loose.ok, loose.issues
    assert len(loose.notes) == 1 and "largest deviation of 2.00e-06" in loose.notes[0]
