"""Kill generation with SIGKILL, look at what is on disk, run again: same dataset as uninterrupted."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from libero_data.pipeline.validate import validate
from tests.pipeline.conftest import TINY, data_table, run_cli

pytestmark = pytest.mark.sim


def test_sigkill_then_rerun_completes_the_same_dataset(tiny_dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "resumed"
    command = [
        sys.executable,
        "-m",
        "libero_data.cli",
        "generate",
        *TINY,
        "--out",
        str(out),
        "--workers",
        "2",
        "--publish-every",
        "0",
    ]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "SVT_LOG": "1"}
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    deadline = time.monotonic() + 600
    try:
        published = out / "meta" / "info.json"
        while not published.is_file():
            # Look at the file again once the process has ended: on a busy machine the last
            # publish and the exit can both fall between the two checks.
            ended = proc.poll() is not None
            assert not ended or published.is_file(), "generation ended without publishing an episode"
            assert time.monotonic() < deadline
            time.sleep(0.2)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()

    # What is on disk after the kill is a loadable dataset of the finished episodes.
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    partial = LeRobotDataset("libero-data/libero_goal", root=out)
    assert 1 <= partial.num_episodes <= 2
    assert partial[len(partial) - 1]["task"]
    assert not validate(out).issues

    result = run_cli("generate", *TINY, "--out", str(out))
    assert result.returncode == 0, result.stderr[-2000:]
    assert not validate(out, resimulate=1).issues
    # Nothing lost, nothing duplicated: exactly the uninterrupted run's content.
    assert data_table(out).equals(data_table(tiny_dataset))
    ours = (out / "meta" / "libero_episodes.jsonl").read_text()
    assert ours == (tiny_dataset / "meta" / "libero_episodes.jsonl").read_text()
    assert json.loads((out / "meta" / "info.json").read_text())["total_episodes"] == 2
    # Finished: the folder holds the dataset only (nothing of the work to upload by mistake), and
    # the same command again has nothing to do.
    assert sorted(p.name for p in out.iterdir()) == ["README.md", "data", "mcap", "meta", "videos"]
    again = run_cli("generate", *TINY, "--out", str(out))
    assert again.returncode == 0 and "done: 2 episodes" in again.stdout, again.stderr[-2000:]


def test_changed_settings_are_refused(tiny_dataset: Path) -> None:
    args = [a if a != "3" else "4" for a in TINY]  # another seed
    result = run_cli("generate", *args, "--out", str(tiny_dataset), timeout=120)
    assert result.returncode == 2
    assert "different settings (seed)" in result.stderr


def test_publishing_is_spaced_to_a_bounded_share_of_the_run() -> None:
    from libero_data.pipeline.generate import PublishClock

    clock = PublishClock(60.0, share=0.05, now=0.0)
    assert not clock.due(now=59.0) and clock.due(now=60.0)
    clock.published(60.0, 61.0)  # a quick snapshot: the interval stays as asked
    assert not clock.due(now=120.9) and clock.due(now=121.0)
    clock.published(121.0, 141.0)  # a 20-s snapshot: wait 19 × 20 s, so it is 5% of the time
    assert not clock.due(now=140.9 + 380) and clock.due(now=141.0 + 380)
    every_time = PublishClock(0.0, now=0.0)
    assert every_time.due(now=0.0)
    every_time.published(0.0, 0.5)
    assert not every_time.due(now=9.9) and every_time.due(now=10.0)
