"""A tiny generated dataset shared by the pipeline and benchmark tests (made once per session)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

#: Two short tasks (open a drawer, turn on the stove), one episode each, small images.
TINY = [
    "--suite",
    "libero_goal",
    "--tasks",
    "0,7",
    "--episodes-per-task",
    "1",
    "--image-size",
    "64",
    "--seed",
    "3",
]


def run_cli(
    *args: str, timeout: float = 900, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "SVT_LOG": "1", **(env or {})}
    return subprocess.run(
        [sys.executable, "-m", "libero_data.cli", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
    )


def make_tiny_dataset(out: Path) -> Path:
    # One worker (the default): the Ray and kill-and-resume tests run two and compare their
    # datasets with this one, which is what shows the worker count changes nothing. The work
    # files stay: tests read the search records.
    result = run_cli("generate", *TINY, "--keep-work", "--out", str(out))
    assert result.returncode == 0, result.stderr[-3000:]
    return out


#: A two-task procedural suite from quick templates (a stove knob, a drawer), one episode each.
PROCEDURAL = [
    "--procedural",
    "2",
    "--seed",
    "0",
    "--template",
    "turn_on_stove,open_drawer",
    "--episodes-per-task",
    "1",
    "--image-size",
    "64",
]


def make_procedural_suite(out: Path) -> Path:
    result = run_cli("generate", *PROCEDURAL, "--out", str(out), "--workers", "2")
    assert result.returncode == 0, result.stderr[-3000:]
    return out
