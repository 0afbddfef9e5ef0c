"""The finished runs of the five lifelong algorithms (issue 59, ``benchmarks/results/lifelong/runs/``)
are whole runs of the quick preset on the same sequence, data, seed and starts as ER's, and RESULTS
states their held-out numbers as the run files give them.

Reads the committed files only (no training, no simulation). The table of the five and the
findings' verdicts get their test when SeqL and MTL are done.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmarks.lifelong_report import NAMES, SWEPT, pick, sweep_rows
from libero_bench.train.presets import get_preset

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "lifelong"
RUNS = RESULTS / "runs"
RESULTS_MD = RESULTS.parents[1] / "RESULTS.md"
#: The runs of the five finished so far (SeqL and MTL are carried: benchmarks/results/lifelong/carry/).
DONE = ("er", "ewc", "packnet")


@pytest.mark.parametrize("algo", DONE)
def test_each_finished_run_is_a_whole_quick_run_on_the_same_sequence_data_and_starts(algo: str) -> None:
    folder = RUNS / f"{algo}-s0"
    config = json.loads((folder / "config.json").read_text())
    results = json.loads((folder / "results.json").read_text())
    reference = json.loads((RUNS / "er-s0" / "config.json").read_text())
    assert config["algo"] == algo and config["seed"] == 0 and config["policy"] == "resnet_t"
    assert config["preset"] == get_preset("quick").to_dict(), f"{algo}-s0 was made with another quick preset"
    assert results["complete"] and results["stage"] == ["done"] * 3
    for key in ("tasks", "dataset", "data", "evaluation", "policy_config"):
        assert config[key] == reference[key], f"{algo}-s0 differs from er-s0 in {key}"
    if algo in SWEPT:  # the sweep's kept setting (test_committed_lifelong.py checks which is kept)
        kept = json.loads((RUNS / pick(sweep_rows(RUNS)[algo])["run"] / "config.json").read_text())
        assert config["algo_config"] == kept["algo_config"]


@pytest.mark.parametrize("algo", DONE)
def test_results_md_states_each_finished_runs_held_out_numbers(algo: str) -> None:
    from libero_bench.runs.folder import HELDOUT
    from libero_bench.runs.intervals import metric_summary
    from libero_bench.runs.summary import load_run

    text = " ".join(RESULTS_MD.read_text().replace("−", "-").split())
    numbers = metric_summary([load_run(RUNS / f"{algo}-s0").draws(HELDOUT)])
    for metric in ("fwt", "nbt", "auc"):
        stat = numbers[metric]
        stated = f"{stat['mean']:.2f} [{stat['low']:.2f}, {stat['high']:.2f}]"
        assert stated in text, f"RESULTS.md lacks {NAMES[algo]}'s held-out {metric.upper()} {stated}"
