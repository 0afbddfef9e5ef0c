"""The committed expert table in ``cards/`` is whole and meets the targets it is held to.

Reads the committed files only (no simulation): a table with a task missing, a suite under
its target or a task under the floor must not land.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

from libero_data.cards.expert_table import TARGETS, TASK_FLOOR
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


def test_every_suite_meets_its_target_and_every_task_the_floor() -> None:
    rows = _rows()
    for suite, target in TARGETS.items():
        mine = [r for r in rows if r["suite"] == suite]
        rate = sum(int(r["successes"]) for r in mine) / sum(int(r["episodes"]) for r in mine)
        assert rate >= target, f"{suite}: {rate:.1%} < {target:.0%}"
    low = [(r["suite"], r["index"]) for r in rows if int(r["successes"]) / int(r["episodes"]) < TASK_FLOOR]
    assert low == []


def test_the_tables_and_cards_come_from_one_report() -> None:
    lines = (CARDS / "expert_report.jsonl").read_text().splitlines()
    settings = json.loads(lines[0])
    measured = {row["ref"]: row["successes"] for row in map(json.loads, lines[1:])}
    assert measured == {f"{r['suite']}/{r['index']}": int(r["successes"]) for r in _rows()}
    code = settings["settings"]["expert"]
    assert f"expert code: {code}" in (CARDS / "expert_report.md").read_text()
    for suite in TARGETS:
        assert f"expert code {code}" in (CARDS / f"{suite}.md").read_text(), suite
