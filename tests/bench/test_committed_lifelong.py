"""The committed lifelong results of issue 59 (``benchmarks/results/lifelong/``) are what
``benchmarks/lifelong_report.py`` makes from the committed run files, and what RESULTS states.

Reads the committed files only (no training, no simulation).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmarks.lifelong_report import SWEPT, pick, sweep_markdown, sweep_rows
from libero_bench.train.presets import get_preset

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "lifelong"
RESULTS_MD = RESULTS.parents[1] / "RESULTS.md"
SWEEP_RUNS = sorted(p.name for p in (RESULTS / "runs").glob("sweep-*"))


def test_the_sweep_table_is_what_the_report_makes_of_the_committed_runs() -> None:
    sweeps = sweep_rows(RESULTS / "runs")
    assert sorted(sweeps) == sorted(SWEPT)
    assert (RESULTS / "sweep.md").read_text() == sweep_markdown(sweeps)
    assert json.loads((RESULTS / "sweep.json").read_text()) == json.loads(json.dumps(sweeps))
    assert {a: pick(rows)["run"] for a, rows in sweeps.items()} == {
        "ewc": "sweep-ewc-500",
        "packnet": "sweep-packnet-075",
    }  # what RESULTS and lifelong.sh's `five` keep


@pytest.mark.parametrize("name", SWEEP_RUNS)
def test_each_sweep_run_learned_two_tasks_with_the_quick_preset(name: str) -> None:
    folder = RESULTS / "runs" / name
    config = json.loads((folder / "config.json").read_text())
    results = json.loads((folder / "results.json").read_text())
    assert config["preset"] == get_preset("quick").to_dict(), f"{name} was made with another quick preset"
    assert config["algo"] in SWEPT and len(config["tasks"]) == 3
    assert results["stage"][:2] == ["done", "done"] and not results["complete"]  # stopped after two tasks


def test_results_md_states_the_sweep_as_committed() -> None:
    text = " ".join(RESULTS_MD.read_text().split())
    for algo, rows in sweep_rows(RESULTS / "runs").items():
        for row in rows:
            auc = row["auc"]
            stated = f"{auc['mean']:.2f} [{auc['low']:.2f}, {auc['high']:.2f}]"
            assert stated in text, f"RESULTS.md lacks {algo}'s AUC {stated} at {row['value']}"
