"""The committed runs of the lifelong algorithms and architectures (issues 59 and 78,
``benchmarks/results/lifelong/``): each is a whole run of the quick preset on the same sequence,
data and starts, with the seed and policy its name says; the committed report, comparisons and
findings are what ``benchmarks/lifelong_report.py`` makes from the run files; RESULTS and README
state the table's held-out numbers and each finding's verdict.

Reads the committed files only (no training, no simulation); the seven paired comparisons take
~15 s.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from benchmarks.lifelong_findings import POLICY_IDS, RUN_NAME, method_runs
from benchmarks.lifelong_report import (
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


RUN_NAMES = [p.name for runs in method_runs(RUNS).values() for p in runs]


@pytest.mark.parametrize("name", RUN_NAMES)
def test_each_run_is_a_whole_quick_run_on_the_same_sequence_data_and_starts(name: str) -> None:
    folder = RUNS / name
    match = RUN_NAME.match(name)
    assert match is not None
    algo, policy = match["algo"], POLICY_IDS[match["policy"] or ""]
    config = json.loads((folder / "config.json").read_text())
    results = json.loads((folder / "results.json").read_text())
    reference = json.loads((RUNS / "er-s0" / "config.json").read_text())
    assert config["algo"] == algo and config["seed"] == int(match["seed"]) and config["policy"] == policy
    assert config["preset"] == get_preset("quick").to_dict(), f"{name} was made with another quick preset"
    assert results["complete"] and results["stage"] == ["done"] * 3
    same = ("tasks", "dataset", "data", "evaluation") + (("policy_config",) if policy == "resnet_t" else ())
    for key in same:
        assert config[key] == reference[key], f"{name} differs from er-s0 in {key}"
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
    assert {(g["algo"], g["policy"]) for g in committed["groups"]} == {
        (
            json.loads((p / "config.json").read_text())["algo"],
            json.loads((p / "config.json").read_text())["policy"],
        )
        for p in (RUNS / n for n in RUN_NAMES)
    }
    for name in files:
        assert (RESULTS / "report" / name).is_file(), f"report/{name} is listed but missing"
    assert (RESULTS / "report" / "report.md").read_text() == "# libero-bench report\n\n" + markdown_table(
        made["summary"]
    )


def test_committed_findings_and_comparisons_are_what_the_run_files_give(made: dict[str, Any]) -> None:
    from libero_bench.analysis.seeds import seeds_markdown

    record = made["record"]
    assert json.loads((RESULTS / "findings.json").read_text()) == record
    assert (RESULTS / "findings.md").read_text() == findings_document(RUNS, made["summary"], record)
    for name, result in record["comparisons"].items():
        assert (RESULTS / "compare" / f"{name}.md").read_text() == seeds_markdown(result), name
    for entry in record["findings"]:  # untested only where it says why: one suite, or runs not made yet
        if entry["heldout"]["verdict"] == "not tested":
            assert entry["untested"] or entry["missing_runs"], entry["key"]
        else:
            assert not entry["missing_runs"], entry["key"]


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
