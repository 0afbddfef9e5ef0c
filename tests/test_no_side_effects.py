"""Importing the packages does nothing visible: no env vars, no files, no heavy modules."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

IMPORT_CHECK = """
import os, sys, json
before = dict(os.environ)
import libero_data, libero_data.cli, libero_data.sim, libero_data.tasks, libero_data.bddl
import libero_bench, libero_bench.cli
heavy = sorted(m for m in ("robosuite", "mujoco", "torch", "lerobot", "libero", "rerun", "datasets") if m in sys.modules)
print(json.dumps({"env_changed": dict(os.environ) != before, "heavy": heavy}))
"""


def test_import_has_no_side_effects(tmp_path: Path) -> None:
    env = {**os.environ, "HOME": str(tmp_path)}
    result = subprocess.run(
        [sys.executable, "-c", IMPORT_CHECK], capture_output=True, text=True, env=env, check=True
    )
    assert result.stdout.strip() == '{"env_changed": false, "heavy": []}'
    assert list(tmp_path.iterdir()) == []


ENV_CHECK = """
import logging
from libero_data.sim import EnvConfig, LiberoEnv
with LiberoEnv("libero_object/1", EnvConfig(cameras=())) as env:
    env.reset(seed=0, render=False)
handlers = [h for h in logging.getLogger("robosuite_logs").handlers if isinstance(h, logging.FileHandler)]
print(len(handlers))
"""


@pytest.mark.sim
def test_environment_writes_nothing_outside_given_paths(tmp_path: Path) -> None:
    env = {**os.environ, "HOME": str(tmp_path)}
    result = subprocess.run(
        [sys.executable, "-c", ENV_CHECK], capture_output=True, text=True, env=env, check=True
    )
    assert result.stdout.strip().splitlines()[-1] == "0", "robosuite's /tmp log file must stay closed"
    assert "private macro file" not in result.stderr
    assert list(tmp_path.iterdir()) == []
