"""The committed expert table in ``cards/`` is whole and meets the targets it is held to, and every
committed table, plot and suite card is what today's code makes from the committed journals.

Reads the committed files only (no simulation): a table with a task missing, a suite whose
95% interval lies under its target or a task whose interval lies under the floor must not land,
nor a table or card left stale by a change of the code that writes it.
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


#: The folders whose expert report tables (and length plot) are written from their journal.
REPORTS = ("", "libero_pro", "libero_plus")


@pytest.mark.parametrize("folder", REPORTS)
def test_the_committed_tables_are_what_the_report_code_makes_of_their_journal(
    folder: str, tmp_path: Path
) -> None:
    """Written again from ``expert_report.jsonl`` alone (``libero-data expert-report --tables-only``):
    the CSV, the Markdown (success within the standard limit beside success at all) and the plot."""
    import shutil

    from libero_data.cards.expert_files import rewrite_report
    from libero_data.cards.expert_table import LENGTH_PLOT

    committed = CARDS / folder
    shutil.copy(committed / "expert_report.jsonl", tmp_path)
    rewrite_report(tmp_path)
    for name in ("expert_report.csv", "expert_report.md"):
        assert (tmp_path / name).read_text() == (committed / name).read_text(), f"{folder}/{name} is stale"
    assert (tmp_path / LENGTH_PLOT).read_bytes() == (committed / LENGTH_PLOT).read_bytes(), folder


@pytest.mark.parametrize("suite", sorted(TARGETS))
def test_the_committed_suite_cards_are_what_the_card_code_makes_of_the_report(suite: str) -> None:
    """``libero-data card --suite S --expert-report cards/expert_report.csv --out cards/S.md``: the
    card (its versions are the lock's) and its length plot."""
    from libero_data.cards.expert_files import read_measured, report_settings
    from libero_data.pipeline.describe import suite_card

    text, plot = suite_card(
        suite,
        read_measured(CARDS / "expert_report.csv"),
        measured_by=report_settings(CARDS / "expert_report.jsonl"),
        lengths_image=f"{suite}_lengths.png",
    )
    assert text == (CARDS / f"{suite}.md").read_text(), f"cards/{suite}.md is stale"
    assert plot == (CARDS / f"{suite}_lengths.png").read_bytes()


def test_the_cards_state_success_within_the_standard_limit_beside_success_at_all() -> None:
    from libero_data.cards.expert_table import summarise, within_words
    from libero_data.experts.report import read_report

    summary = summarise(list(read_report(CARDS / "expert_report.jsonl")[1].values()))
    table = (CARDS / "expert_report.md").read_text()
    for suite, s in summary.items():
        assert f"| {within_words(s)} | {s['limit']:.0f} |" in table, suite
        card = (CARDS / f"{suite}.md").read_text()
        assert f"within the standard limit {int(s['within'])}/{int(s['episodes'])} (" in card, suite
        assert f"| length bound (steps) | {s['limit']:.0f} steps: each task's standard limit" in card


def test_every_task_under_its_within_limit_floor_says_why() -> None:
    """Issue 74: a task of the five suites under 95% of its stored starts within the standard limit,
    or a LIBERO-PRO or LIBERO-Plus task under 80%, is named in its table with the reason the
    expert cannot do it in time (``libero_data/cards/expert_limits.json``); a reason whose task is
    no longer under its floor (or in no committed table) is stale."""
    from libero_data.cards.expert_table import short_tasks
    from libero_data.cards.limits import stated_reasons
    from libero_data.experts.report import read_report

    short, measured = set(), set()
    for folder in REPORTS:
        results = list(read_report(CARDS / folder / "expert_report.jsonl")[1].values())
        measured |= {f"{r.suite}/{r.index}" for r in results}
        short |= {f"{r.suite}/{r.index}" for r in short_tasks(results)}
    reasons = stated_reasons()
    assert sorted(short - set(reasons)) == [], "tasks under their floor without a stated reason"
    assert sorted(set(reasons) - short) == [], "reasons for tasks not under their floor"
    assert set(reasons) <= measured
