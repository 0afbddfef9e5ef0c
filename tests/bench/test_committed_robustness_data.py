"""The committed robustness-through-data experiment (``benchmarks/results/robustness_data/``,
issue 36) is what its script makes and what README states of it.

Reads the committed files only (no training, no simulation): for every task swept, the two runs
differ only in the mixed-in variant data (same preset, policy, seed, data and gradient steps),
the held-out starts avoided every training episode's start, both sweeps rolled out from the same
held-out starts, the summary is what the report makes from the committed sweeps, and README
states its level-3 figure.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from benchmarks.robustness_data_report import TASKS, summary

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "robustness_data"
SWEPT = [t for t in TASKS if (RESULTS / "sweeps" / f"mixed-{t}" / "robustness.json").is_file()]


def _json(*parts: str) -> Any:
    return json.loads(RESULTS.joinpath(*parts).read_text())


def test_at_least_one_task_is_committed() -> None:
    assert "object-0" in SWEPT


@pytest.mark.parametrize("task", SWEPT)
def test_the_two_runs_differ_only_in_the_variant_data(task: str) -> None:
    single, mixed = (_json("runs", f"{arm}-{task}", "config.json") for arm in ("single", "mixed"))
    assert "mix" not in single and mixed["mix"]["weight"] == 0.5
    assert mixed["mix"]["datasets"][0]["episodes"] == 300
    for key in set(single) - {"evaluation", "mix"}:
        assert single[key] == mixed[key], key
    for config, demos in ((single, 100), (mixed, 400)):
        for starts in config["evaluation"]["training_starts"].values():
            # the held-out starts avoid every training episode's start, variants included
            assert starts["demos_from_sampler"] == demos and starts["demos_from_stored_inits"] == 0
            assert starts["stored_eval_starts_trained_on"] == []
    steps = [
        [
            json.loads(line)["batches"]
            for line in (RESULTS / "runs" / f"{arm}-{task}" / "timings.jsonl").open()
            if json.loads(line)["what"] == "epoch"
        ]
        for arm in ("single", "mixed")
    ]
    # the same budget: as many batches in every epoch (epoch 0 only measures the loss, untrained)
    assert steps[0] == steps[1] and len(steps[0]) == single["preset"]["epochs"] + 1


@pytest.mark.parametrize("task", SWEPT)
def test_both_sweeps_start_from_the_same_heldout_starts(task: str) -> None:
    single, mixed = (_json("sweeps", f"{arm}-{task}", "robustness.json") for arm in ("single", "mixed"))
    assert single["heldout_seeds"] == mixed["heldout_seeds"]
    assert single["request"] == mixed["request"]
    assert single["request"]["levels"] == [1, 3, 5] and single["request"]["rollouts"] == 10


def test_the_summary_is_what_the_report_makes_and_readme_states_it(tmp_path: Path) -> None:
    copy = tmp_path / "results"
    shutil.copytree(RESULTS / "sweeps", copy / "sweeps")
    text = summary(copy)
    assert text == (RESULTS / "summary.md").read_text()
    level3 = next(line for line in text.splitlines() if line.startswith("| trained kinds, level 3 |"))
    figure = level3.split("|")[2].strip()  # B − A, e.g. "+23%"
    readme = " ".join((RESULTS.parents[2] / "README.md").read_text().replace("**", "").split())
    assert f"trained kinds at level 3: {figure}" in readme
