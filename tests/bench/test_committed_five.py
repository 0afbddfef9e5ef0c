"""The committed runs of the five lifelong algorithms (issue 59, ``benchmarks/results/lifelong/``):
each is a whole run of the quick preset on the same sequence, data, seed and starts; the committed
report, comparisons and findings are what ``benchmarks/lifelong_report.py`` makes from the run
files; RESULTS and README state the table's held-out numbers and each finding's verdict.

Reads the committed files only (no training, no simulation); the seven paired comparisons take
~15 s.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from benchmarks.lifelong_report import (
    ALGOS,
    NAMES,
    SWEPT,
    findings_document,
    findings_record,
    pick,
    report_runs,
    sweep_rows,
)
from libero_bench.train.presets import get_preset

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "lifelong"
RUNS = RESULTS / "runs"
ROOT = RESULTS.parents[2]
RESULTS_MD = ROOT / "benchmarks" / "RESULTS.md"
README = ROOT / "README.md"


def _plain(path: Path) -> str:
    """A document's text with its line breaks and typographic minus signs evened out."""
    return " ".join(path.read_text().replace("−", "-").split())


def _roundtrip(value: Any) -> Any:
    return json.loads(json.dumps(value))


@pytest.fixture(scope="module")
def made() -> dict[str, Any]:
    """What the report script makes from the committed run files, without writing anything."""
    from libero_bench.analysis.report import summarize
    from libero_bench.runs.summary import load_run

    summary = summarize([load_run(p) for p in report_runs(RUNS)], RESULTS / "report")
    return {"summary": _roundtrip(summary), "record": _roundtrip(findings_record(RUNS, RESULTS))}


@pytest.mark.parametrize("algo", ALGOS)
def test_each_run_is_a_whole_quick_run_on_the_same_sequence_data_and_starts(algo: str) -> None:
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


def test_committed_report_is_what_report_makes_from_the_run_files(made: dict[str, Any]) -> None:
    from libero_bench.analysis.report import markdown_table

    committed = json.loads((RESULTS / "report" / "report.json").read_text())
    files = committed.pop("files")
    assert committed == made["summary"], (
        "report/report.json is not what the run files give: run the report again"
    )
    assert {g["algo"] for g in committed["groups"]} == set(ALGOS)
    for name in files:
        assert (RESULTS / "report" / name).is_file(), f"report/{name} is listed but missing"
    assert (RESULTS / "report" / "report.md").read_text() == "# libero-bench report\n\n" + markdown_table(
        made["summary"]
    )


def test_committed_findings_and_comparisons_are_what_the_run_files_give(made: dict[str, Any]) -> None:
    from libero_bench.analysis.compare import comparison_markdown

    record = made["record"]
    assert json.loads((RESULTS / "findings.json").read_text()) == record
    assert (RESULTS / "findings.md").read_text() == findings_document(RUNS, made["summary"], record)
    for name, result in record["comparisons"].items():
        assert (RESULTS / "compare" / f"{name}.md").read_text() == comparison_markdown(result), name
    heldout = {e["key"]: e["heldout"]["verdict"] for e in record["findings"]}
    assert heldout["er_robust_across_suites"] == "not tested"  # one suite at this budget
    assert all(v != "not tested" for k, v in heldout.items() if k != "er_robust_across_suites")


@pytest.mark.parametrize("document", [RESULTS_MD, README], ids=["RESULTS", "README"])
def test_documents_state_the_table_and_each_findings_verdict(document: Path, made: dict[str, Any]) -> None:
    text = _plain(document)
    for group in made["summary"]["groups"]:
        name = NAMES[group["algo"]]
        for metric in ("fwt", "nbt", "auc"):
            stat = group["heldout"][metric]
            stated = f"{stat['mean']:.2f} [{stat['low']:.2f}, {stat['high']:.2f}]"
            assert stated in text, f"{document.name} lacks {name}'s held-out {metric.upper()} {stated}"
    for entry in made["record"]["findings"]:
        stated = f"{entry['text']}: {entry['heldout']['verdict']}"
        assert stated in text, f"{document.name} lacks the verdict '{stated}'"
