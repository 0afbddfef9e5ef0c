"""``libero-data generate --executor ray``: the same dataset as the local executor."""

from __future__ import annotations

from pathlib import Path

import pytest

from libero_data.pipeline.validate import validate
from tests.pipeline.conftest import TINY, data_table, run_cli

# The same xdist worker as tests/bench/test_bench_run.py, so two local Ray instances never overlap.
pytestmark = [pytest.mark.sim, pytest.mark.xdist_group("ray")]


@pytest.mark.slow  # Ray starts in ~a minute; scripts/test runs it after the default suite
def test_ray_executor_writes_the_same_dataset_as_local_workers(tiny_dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "on_ray"
    result = run_cli("generate", *TINY, "--out", str(out), "--executor", "ray", "--workers", "2")
    assert result.returncode == 0, result.stderr[-3000:]
    assert not validate(out).issues
    # Same seed, same request: the same frames, states and actions, episode metadata and videos.
    assert data_table(out).equals(data_table(tiny_dataset))
    ours = (out / "meta" / "libero_episodes.jsonl").read_text()
    assert ours == (tiny_dataset / "meta" / "libero_episodes.jsonl").read_text()
    videos = sorted(p.relative_to(out) for p in (out / "videos").rglob("*.mp4"))
    assert videos == sorted(p.relative_to(tiny_dataset) for p in (tiny_dataset / "videos").rglob("*.mp4"))
    for rel in videos:
        assert (out / rel).read_bytes() == (tiny_dataset / rel).read_bytes()
    # Every byte of the data and of the statistics (written in one order by every process).
    for rel in sorted(p.relative_to(out) for p in (out / "data").rglob("*.parquet")):
        assert (out / rel).read_bytes() == (tiny_dataset / rel).read_bytes(), rel
    stats = Path("meta") / "stats.json"
    assert (out / stats).read_bytes() == (tiny_dataset / stats).read_bytes()


def test_bad_executor_flags_are_one_sentence(tmp_path: Path) -> None:
    bad = run_cli("generate", *TINY, "--out", str(tmp_path / "x"), "--executor", "dask", timeout=120)
    assert bad.returncode == 2 and "choose local or ray" in bad.stderr
    lonely = run_cli("generate", *TINY, "--out", str(tmp_path / "y"), "--ray-address", "auto", timeout=120)
    assert lonely.returncode == 2 and "a Ray address needs the Ray executor (--ray-address)" in lonely.stderr
