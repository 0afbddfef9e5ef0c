"""The committed expert table in ``cards/`` is whole and meets the targets it is held to.

Reads the committed files only (no simulation): a table with a task missing, a suite whose
95% interval lies under its target or a task whose interval lies under the floor must not land.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from libero_data.cards.expert_table import TARGETS, TASK_FLOOR
from libero_data.stats import wilson_interval
from libero_data.tasks import SUITE_NAMES, get_suite

CARDS = Path(__file__).resolve().parents[1] / "cards"


def _rows() -> list[dict[str, str]]:
    with (CARDS / "expert_report.csv").open(newline="") as f:
        return list(csv.DictReader(f))


def test_the_table_covers_every_task_of_the_five_suites_with_50_inits() -> None:
    rows = _rows()
    have = [(r["suite"], int(r["index"])) for r in rows]
    want = [(name, t.index) for name in SUITE_NAMES[:5] for t in get_suite(name).tasks]
    assert len(want) == 130
    assert sorted(have) == sorted(want)
    assert {int(r["episodes"]) for r in rows} == {50}


def test_no_suite_falls_short_of_its_target_and_no_task_of_the_floor() -> None:
    # Judged with 95% intervals (libero_data.cards.expert_table): a suite or task falls short
    # only where its whole interval lies under the target or the floor.
    from libero_data.cards.expert_table import falls_short, summarise
    from libero_data.experts.report import TaskResult

    results = [
        TaskResult(r["suite"], int(r["index"]), r["name"], int(r["episodes"]), int(r["successes"]), 0.0, 0.0)
        for r in _rows()
    ]
    summary = summarise(results)
    assert set(summary) >= set(TARGETS)
    short = {suite: falls_short(s) for suite, s in summary.items() if falls_short(s)}
    assert short == {}
    for r in _rows():
        high = wilson_interval(int(r["successes"]), int(r["episodes"]))[1]
        assert high >= TASK_FLOOR, f"{r['suite']}/{r['index']}: {r['successes']}/{r['episodes']}"


def test_the_tables_and_cards_come_from_one_report() -> None:
    lines = (CARDS / "expert_report.jsonl").read_text().splitlines()
    settings = json.loads(lines[0])
    measured = {row["ref"]: row["successes"] for row in map(json.loads, lines[1:])}
    assert measured == {f"{r['suite']}/{r['index']}": int(r["successes"]) for r in _rows()}
    code = settings["settings"]["expert"]
    assert f"expert code: {code}" in (CARDS / "expert_report.md").read_text()
    for suite in TARGETS:
        assert f"expert code {code}" in (CARDS / f"{suite}.md").read_text(), suite


def test_the_libero_pro_table_covers_its_16_suites_with_50_inits_by_the_same_expert() -> None:
    from libero_data.tasks.suites import pro_suite_names

    folder = CARDS / "libero_pro"
    with (folder / "expert_report.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    families = [name for name in pro_suite_names() if "_temp_" not in name]
    assert len(families) == 16
    want = [(name, t.index) for name in families for t in get_suite(name).tasks]
    assert sorted((r["suite"], int(r["index"])) for r in rows) == sorted(want)
    assert {int(r["episodes"]) for r in rows} == {50}
    lines = (folder / "expert_report.jsonl").read_text().splitlines()
    measured = {row["ref"]: row["successes"] for row in map(json.loads, lines[1:])}
    assert measured == {f"{r['suite']}/{r['index']}": int(r["successes"]) for r in rows}
    # the expert of the 130 tasks' table, measured on the same numeric path
    main = json.loads((CARDS / "expert_report.jsonl").read_text().splitlines()[0])["settings"]
    settings = json.loads(lines[0])["settings"]
    assert settings["expert"] == main["expert"] and settings["inits"] == main["inits"] == 50
    assert f"expert code: {settings['expert']}" in (folder / "expert_report.md").read_text()


def test_the_libero_plus_card_covers_its_sample_by_the_main_tables_expert(
    plus_wheel: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """cards/libero_plus (benchmarks/plus_expert.py): every task of the stratified sample it names
    measured, by the expert of the 130 tasks' table, and its by-category table made from them."""
    from benchmarks.plus_expert import by_category, markdown, sample_refs
    from libero_data.tasks.plus import ENV_VAR

    monkeypatch.setenv(ENV_VAR, str(plus_wheel))
    folder = CARDS / "libero_plus"
    record = json.loads((folder / "by_category.json").read_text())
    settings = record["settings"]
    lines = (folder / "expert_report.jsonl").read_text().splitlines()
    rows = [json.loads(line) for line in lines[1:]]
    assert sorted(r["ref"] for r in rows) == sorted(
        sample_refs(settings["per_category"], settings["sample_seed"])
    )
    table = by_category(rows)
    assert record["table"] == json.loads(json.dumps(table))
    assert (folder / "by_category.md").read_text() == markdown(table, settings)
    main = json.loads((CARDS / "expert_report.jsonl").read_text().splitlines()[0])["settings"]
    assert settings["expert"] == main["expert"]
