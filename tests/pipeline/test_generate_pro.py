"""``libero-data generate`` on LIBERO-PRO's suites: the expert makes the demonstrations LIBERO-PRO
lacks, from the perturbed task's own BDDL and init states."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from libero_data.tasks import get_task
from tests.tiny_data import run_cli

pytestmark = [pytest.mark.sim, pytest.mark.slow]


def test_generate_makes_demonstrations_of_a_pro_suite(tmp_path: Path) -> None:
    # Turn on the stove, in LIBERO-PRO's version of libero_goal whose objects start elsewhere.
    out = tmp_path / "swap"
    done = run_cli(
        "generate",
        "--suite",
        "libero_goal_swap",
        "--tasks",
        "7",
        "--episodes-per-task",
        "1",
        "--image-size",
        "32",
        "--seed",
        "0",
        "--out",
        str(out),
    )
    assert done.returncode == 0, done.stderr[-3000:]
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 1
    task = get_task("libero_goal_swap/7")
    card = (out / "README.md").read_text()
    assert "libero_goal_swap" in card and task.language in card
    # The perturbed task's own BDDL (its objects' regions differ from libero_goal's), not the base's.
    stored = (out / "meta" / "bddl" / f"{task.name}.bddl").read_text()
    assert stored == task.bddl_path.read_text() != get_task("libero_goal/7").bddl_path.read_text()
