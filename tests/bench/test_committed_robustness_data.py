"""The committed robustness-through-data experiment (``benchmarks/results/robustness_data/``,
issue 36) is what its script makes and what benchmarks/RESULTS.md states of it.

Reads the committed files only (no training, no simulation): for every task swept, the two runs
differ only in the mixed-in variant data (same preset, policy, seed, data and gradient steps),
the held-out starts avoided every training episode's start, both sweeps rolled out from the same
held-out starts, the summary is what the report makes from the committed sweeps, and
benchmarks/RESULTS.md states its pooled level-3 figure (the docs link there, and retell no figure).
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path
from typing import Any

import pytest

from benchmarks.robustness_data_report import LEVERS, TASKS, TRAINED, summary

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "robustness_data"
SWEPT = [t for t in TASKS if (RESULTS / "sweeps" / f"mixed-{t}" / "robustness.json").is_file()]
LEVER_RUNS = [
    (lever, task)
    for lever in LEVERS
    for task in SWEPT
    if (RESULTS / "sweeps" / f"{lever}-{task}" / "robustness.json").is_file()
]
# variant episodes mixed into each lever's run (three draws of 300 for mixed-more)
LEVER_MIX = {"single-aug": [], "mixed-aug": [300], "mixed-long": [300], "mixed-more": [300, 300, 300]}


def _json(*parts: str) -> Any:
    return json.loads(RESULTS.joinpath(*parts).read_text())


def _batches(run: str) -> list[int]:
    lines = (json.loads(line) for line in (RESULTS / "runs" / run / "timings.jsonl").open())
    return [line["batches"] for line in lines if line["what"] == "epoch"]


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
    steps = [_batches(f"{arm}-{task}") for arm in ("single", "mixed")]
    # the same budget: as many batches in every epoch (epoch 0 only measures the loss, untrained)
    assert steps[0] == steps[1] and len(steps[0]) == single["preset"]["epochs"] + 1


@pytest.mark.parametrize("task", SWEPT)
def test_both_sweeps_start_from_the_same_heldout_starts(task: str) -> None:
    single, mixed = (_json("sweeps", f"{arm}-{task}", "robustness.json") for arm in ("single", "mixed"))
    assert single["heldout_seeds"] == mixed["heldout_seeds"]
    assert single["request"] == mixed["request"]
    assert single["request"]["levels"] == [1, 3, 5] and single["request"]["rollouts"] == 10


def test_levers_are_committed() -> None:
    assert ("mixed-more", "spatial-8") in LEVER_RUNS and ("single-aug", "spatial-8") in LEVER_RUNS
    assert (RESULTS / "pooled" / "levers" / "mixed-more" / "compare.json").is_file()


@pytest.mark.parametrize(("lever", "task"), LEVER_RUNS)
def test_each_lever_run_kept_the_budget_and_the_heldout_starts(lever: str, task: str) -> None:
    """A lever's run is paired with A's and B's cells: the same gradient steps per epoch, held-out
    starts that avoided every episode it trained on (every variant draw included), and a level-3
    sweep of the trained kinds from A's held-out starts."""
    config = _json("runs", f"{lever}-{task}", "config.json")
    mixed = [dataset["episodes"] for dataset in config.get("mix", {}).get("datasets", [])]
    assert mixed == LEVER_MIX[lever]
    assert not mixed or config["mix"]["weight"] == 0.5
    for starts in config["evaluation"]["training_starts"].values():
        assert starts["demos_from_sampler"] == 100 + sum(mixed) and starts["demos_from_stored_inits"] == 0
        assert starts["stored_eval_starts_trained_on"] == []
    assert _batches(f"{lever}-{task}") == _batches(f"single-{task}")
    swept, a = (_json("sweeps", f"{run}-{task}", "robustness.json") for run in (lever, "single"))
    assert swept["heldout_seeds"] == a["heldout_seeds"]
    assert swept["request"]["levels"] == [3] and sorted(swept["request"]["kinds"]) == sorted(TRAINED)
    same = {"levels": None, "kinds": None}  # all else as A's sweep: rollouts, seed, horizon, rendering
    assert swept["request"] | same == a["request"] | same


def test_the_summary_is_what_the_report_makes_and_results_states_it(tmp_path: Path) -> None:
    copy = tmp_path / "results"
    shutil.copytree(RESULTS / "sweeps", copy / "sweeps")
    text = summary(copy)
    assert text == (RESULTS / "summary.md").read_text()
    # the pooled comparisons behind the levers' rows are the committed ones
    for compared in sorted((RESULTS / "pooled" / "levers").glob("*/compare.json")):
        made, committed = (
            json.loads(p.read_text()) for p in (copy / compared.relative_to(RESULTS), compared)
        )
        for report in (made, committed):  # where the sweeps were read from differs, not what they hold
            for arm in ("a", "b"):
                report[arm]["sweeps"] = [Path(sweep).name for sweep in report[arm]["sweeps"]]
        assert made == committed, compared.parent.name
    level3 = next(line for line in text.splitlines() if line.startswith("| trained kinds, level 3 |"))
    figure = level3.split("|")[2].strip()  # B − A, e.g. "+23%"
    stated = (RESULTS.parents[1] / "RESULTS.md").read_text().replace("**", "")
    # the section's table per task and pooled: what | object-0 | spatial-8 | pooled
    (row,) = [
        r for r in stated.splitlines() if r.startswith("| trained kinds, level 3 |") and r.count("|") == 5
    ]
    assert row.split("|")[4].strip().startswith(f"{figure} ["), row
    # and the targets' table at the top
    assert re.search(rf"pooled {re.escape(figure)} \[[^\]]*\] at level 3", " ".join(stated.split()))
