"""Which standard step limit each kind of task gets (``libero_data.tasks.horizons.standard_limit``):
the one rule the expert report, the cards and ``generate``'s length bound share."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from libero_data.tasks import get_suite
from libero_data.tasks.horizons import (
    OPENPI_LIMITS,
    OTHER_LIMIT,
    SUITE,
    SUITE_LIMITS,
    base_suite,
    standard_limit,
    step_limit,
)

PROCEDURAL = Path(__file__).resolve().parents[2] / "cards" / "procedural"


def _variants_folder(folder: Path, source: str) -> Path:
    """A suite folder as ``generate --variants-of SOURCE`` writes its manifest."""
    folder.mkdir()
    settings = {"n": 1, "seed": 0, "variants_of": source, "kinds": ["camera"]}
    manifest = {"name": folder.name, "generator": {"settings": settings}, "tasks": []}
    (folder / "suite.json").write_text(json.dumps(manifest))
    return folder


def test_the_five_suites_take_openpis_limits() -> None:
    assert OPENPI_LIMITS == {
        "libero_spatial": 220,
        "libero_object": 280,
        "libero_goal": 300,
        "libero_10": 520,
        "libero_90": 400,
    }
    for suite, limit in OPENPI_LIMITS.items():
        assert base_suite(suite) == suite and standard_limit(suite) == limit
        assert standard_limit(get_suite(suite)) == limit


@pytest.mark.parametrize(
    ("suite", "base"),
    [
        ("libero_spatial_swap", "libero_spatial"),
        ("libero_goal_lan", "libero_goal"),
        ("libero_10_task", "libero_10"),
        ("libero_object_object", "libero_object"),
        ("libero_object_temp_x0.3", "libero_object"),  # LIBERO-PRO's position shifts
        ("plus/libero_spatial", "libero_spatial"),  # LIBERO-Plus's
        ("plus/libero_10", "libero_10"),
    ],
)
def test_libero_pro_and_plus_suites_take_their_base_suites(suite: str, base: str) -> None:
    assert base_suite(suite) == base
    assert standard_limit(suite) == OPENPI_LIMITS[base]
    assert standard_limit(suite, "any_task_name") == OPENPI_LIMITS[base]


def test_libero_100s_tasks_take_the_limit_of_the_suite_that_holds_them() -> None:
    suite = get_suite("libero_100")
    first, last = suite.tasks[0], suite.tasks[-1]
    assert standard_limit(suite, first.name) == 400 == standard_limit("libero_100", first.name)  # libero_90's
    assert standard_limit(suite, last.name) == 520  # libero_10's
    assert base_suite("libero_100") is None and standard_limit("libero_100") == OTHER_LIMIT  # no task named


def test_robustness_variants_take_their_source_suites(tmp_path: Path) -> None:
    goal = _variants_folder(tmp_path / "goal_variants", "libero_goal")
    assert base_suite(str(goal)) == "libero_goal" and standard_limit(str(goal)) == 300
    # variants of a LIBERO-PRO suite, and variants of those variants (a folder names the folder)
    pro = _variants_folder(tmp_path / "pro_variants", "libero_spatial_swap")
    again = _variants_folder(tmp_path / "again", str(pro))
    assert standard_limit(str(pro)) == standard_limit(str(again)) == 220
    # a folder whose manifest names itself does not loop
    looped = _variants_folder(tmp_path / "looped", str(tmp_path / "looped"))
    assert standard_limit(str(looped)) == OTHER_LIMIT


def test_procedural_tasks_have_no_base_suite_and_take_the_other_limit(tmp_path: Path) -> None:
    # cards/procedural: new tasks sampled in LIBERO's scenes (its manifest names no suite)
    suite = get_suite(str(PROCEDURAL))
    assert base_suite(suite) is None and base_suite(str(PROCEDURAL)) is None
    assert standard_limit(suite, suite.tasks[0].name) == OTHER_LIMIT == 500
    (tmp_path / "bare").mkdir()  # a folder of BDDL files, no manifest
    assert standard_limit(str(tmp_path / "bare")) == OTHER_LIMIT
    assert standard_limit("file") == standard_limit("no_such_suite") == OTHER_LIMIT


def test_evaluation_step_limits_map_suites_as_before() -> None:
    # step_limit shares the mapping to base suites; its limits table stays the caller's.
    assert step_limit(SUITE, "libero_spatial") == SUITE_LIMITS["libero_spatial"] == 280
    assert step_limit(SUITE, "libero_spatial", OPENPI_LIMITS) == 220
    assert step_limit(SUITE, "libero_goal_swap") == 300 and step_limit(SUITE, "plus/libero_10") == 520
    assert step_limit(SUITE, "libero_100") == OTHER_LIMIT and step_limit(64, "libero_10") == 64
