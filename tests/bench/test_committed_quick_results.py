"""The committed ``quick`` results (``benchmarks/results/quick/``) are what today's preset makes
and meet the target the preset is held to.

Reads the committed files only (no training, no simulation): a change of the ``quick`` preset
or of the quick policy size that is not followed by new results (``benchmarks/quick.sh``), a
single-task result under 80% from either kind of start must not land.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from libero_bench.intervals import final_rates
from libero_bench.presets import get_preset
from libero_bench.run_files import STARTS, RunResults

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "quick"
SINGLE = ("single-0", "single-1", "single-2")
TARGET = 0.8


def _run(name: str) -> tuple[dict[str, Any], RunResults]:
    folder = RESULTS / "runs" / name
    return (
        json.loads((folder / "config.json").read_text()),
        RunResults.from_dict(json.loads((folder / "results.json").read_text())),
    )


@pytest.mark.parametrize("name", SINGLE)
def test_each_committed_run_was_made_with_todays_quick_preset_and_policy(name: str) -> None:
    from libero_bench.policies import policy_config

    preset = get_preset("quick")
    config, results = _run(name)
    assert results.complete, f"{name} did not finish"
    assert config["preset"] == preset.to_dict(), (
        f"{name} was made with another quick preset: run benchmarks/quick.sh again"
    )
    policy = policy_config(
        config["policy"], preset.policy_size, image_size=preset.image_size, window=preset.window
    )
    assert config["policy_config"] == policy.to_dict(), f"{name} was made with another quick policy size"
    # demonstrations from the sampler only: the stored evaluation starts are unseen
    for task in config["evaluation"]["training_starts"].values():
        assert task["demos_from_stored_inits"] == 0 and task["stored_eval_starts_trained_on"] == []
        assert task["demos_from_sampler"] == 100
    for start in STARTS:  # every task evaluated from 20 starts of each kind after the last
        final = final_rates(results, len(config["tasks"]), start)  # as `libero-bench report` gives it
        assert [rate.n for rate in final] == [20] * len(config["tasks"])


@pytest.mark.parametrize("position", [0, 1, 2])
def test_each_libero_object_task_trained_alone_reaches_the_target_from_both_kinds_of_start(
    position: int,
) -> None:
    config, results = _run(f"single-{position}")
    assert [t["suite_index"] for t in config["tasks"]] == [position]
    for start in STARTS:
        (final,) = final_rates(results, 1, start)
        assert final.n == 20
        assert final.rate >= TARGET, f"single-{position}, {start} starts: {final.successes}/20"
