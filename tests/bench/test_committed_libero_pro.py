"""The committed LIBERO-PRO evaluation of our libero_object/0 policies (benchmarks/results/libero_pro,
made by benchmarks/libero_pro.sh) is whole and its summary is what the report makes of it."""

from __future__ import annotations

import json
from pathlib import Path

from benchmarks.libero_pro_report import POLICIES, markdown, summary
from libero_bench.evaluation.libero_pro import COLUMNS, pro_markdown

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "libero_pro"


def test_the_summary_is_what_the_report_makes_of_the_committed_folders() -> None:
    made = summary(RESULTS)
    assert json.loads((RESULTS / "summary.json").read_text()) == json.loads(json.dumps(made))
    assert (RESULTS / "summary.md").read_text() == markdown(made)


def test_each_policys_table_counts_its_episodes() -> None:
    for policy in POLICIES:
        table = json.loads((RESULTS / policy / "libero_pro.json").read_text())
        (row,) = table["rows"]
        assert (RESULTS / policy / "libero_pro.md").read_text() == pro_markdown(table)
        for column in COLUMNS:
            cell = row["columns"][column]
            records = json.loads((RESULTS / policy / cell["folder"] / "results.json").read_text())["rollouts"]
            # ten episodes under the standard protocol, from stored init states 0-9
            assert sorted(r["init_index"] for r in records) == list(range(10)), (policy, column)
            assert {r["start"] for r in records} == {"standard"}
            assert cell["successes"] == sum(r["success"] for r in records) and cell["n"] == 10
        default = json.loads((RESULTS / policy / "default" / "results.json").read_text())["rollouts"]
        assert sorted(r["init_index"] for r in default) == list(range(10))  # the same starts, ours
        assert {r["start"] for r in default} == {"stored"}
