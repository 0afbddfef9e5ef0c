"""The committed LIBERO-Plus evaluation of our robustness-data policies (benchmarks/results/libero_plus,
made by benchmarks/libero_plus.sh) is whole, drawn as the script says, and its summary is what the
report makes of it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmarks.libero_plus_report import KINDS, TASKS, markdown, summary
from libero_bench.evaluation.libero_plus import plus_markdown

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "libero_plus"


def test_the_summary_is_what_the_report_makes_of_the_committed_folders() -> None:
    made = summary(RESULTS)
    assert json.loads((RESULTS / "summary.json").read_text()) == json.loads(json.dumps(made))
    assert (RESULTS / "summary.md").read_text() == markdown(made)
    assert set(made["tasks"]) == set(TASKS) and len(made["pooled"]) == 3
    assert (RESULTS / "summary.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for kind in KINDS:  # the pooled rates are each task's together
        pooled = made["pooled_policies"][kind]["total"]
        per_task = [made["tasks"][short]["policies"][kind]["total"] for short in TASKS]
        assert pooled["n"] == sum(t["n"] for t in per_task)
        assert pooled["successes"] == sum(t["successes"] for t in per_task)


@pytest.mark.parametrize(("kind", "short"), [(kind, short) for short in TASKS for kind in KINDS])
def test_each_policy_ran_the_same_tasks_once_from_init_state_0(kind: str, short: str) -> None:
    policy = f"{kind}-{short}"
    table = json.loads((RESULTS / policy / "libero_plus.json").read_text())
    assert (RESULTS / policy / "libero_plus.md").read_text() == plus_markdown(table)
    tasks = []
    for row in table["rows"]:
        records = json.loads((RESULTS / policy / row["folder"] / "results.json").read_text())["rollouts"]
        assert {r["init_index"] for r in records} == {0} and {r["start"] for r in records} == {"standard"}
        tasks += [r["task"] for r in records]
    assert len(tasks) == len(set(tasks))  # each task once
    first = json.loads((RESULTS / f"single-{short}" / "libero_plus.json").read_text())
    assert [r["folder"] for r in first["rows"]] == [r["folder"] for r in table["rows"]]
    every = set()
    for row in first["rows"]:
        path = RESULTS / f"single-{short}" / row["folder"] / "results.json"
        every |= {r["task"] for r in json.loads(path.read_text())["rollouts"]}
    assert set(tasks) == every  # the same tasks for every policy of a task
