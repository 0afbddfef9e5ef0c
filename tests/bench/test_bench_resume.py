"""A run killed in the middle of a task goes on after its last finished epoch, with the same
numbers and weights as one never interrupted (``libero-bench run``, killed with SIGKILL).
Apart from tests/bench/test_bench_run.py, whose tests share one xdist worker with Ray's."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from tests.bench.test_bench_run import RUN_ARGS, _results, bench, kill_once

pytestmark = pytest.mark.sim


def test_a_task_interrupted_between_epochs_goes_on_after_its_last_finished_epoch(
    tiny_dataset: Path, tmp_path: Path
) -> None:
    import torch

    args = ["--data", str(tiny_dataset), *RUN_ARGS, "--set", "epochs=3", "--tasks", "0", "--workers", "1"]
    reference = tmp_path / "reference"
    assert bench("run", *args, "--out", str(reference)).returncode == 0
    out = tmp_path / "interrupted"
    command = [sys.executable, "-m", "libero_bench.cli", "run", *args, "--out", str(out)]
    timings = out / "timings.jsonl"
    # killed once epoch 2 of 3 has finished: its state or epoch 1's is on disk
    kill_once(command, lambda: timings.is_file() and "epoch 2/3" in timings.read_text(), "its second epoch")
    state = out / "checkpoints" / "task_000.epoch.safetensors"
    assert state.is_file() and not (out / "checkpoints" / "task_000.safetensors").exists()
    result = bench("run", *args, "--out", str(out))
    assert result.returncode == 0, result.stderr[-3000:]
    assert "resuming after epoch" in (out / "run.log").read_text()
    assert not state.exists()  # the task ended: its epoch state is gone
    # The same numbers and the same weights as a run that was never interrupted.
    ours, theirs = _results(out), _results(reference)
    assert ours["losses"] == theirs["losses"] and ours["curve"] == theirs["curve"]
    assert ours["rollouts"] == theirs["rollouts"]
    from libero_bench.train.checkpoints import read_checkpoint

    a = read_checkpoint(out / "checkpoints" / "task_000.safetensors")["policy"]
    b = read_checkpoint(reference / "checkpoints" / "task_000.safetensors")["policy"]
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
