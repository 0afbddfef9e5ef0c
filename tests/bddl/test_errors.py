"""Malformed BDDL raises BDDLError naming the file, the line and the problem."""

from __future__ import annotations

from pathlib import Path

import pytest

from libero_data.bddl import BDDLError, parse, parse_file
from libero_data.tasks import get_suite

SOURCE = get_suite("libero_goal").task(0).bddl_path.read_text()


def _line_of(text: str, needle: str) -> int:
    for i, line in enumerate(text.splitlines(), start=1):
        if needle in line:
            return i
    raise AssertionError(needle)


def _break(old: str, new: str, count: int = 1) -> str:
    assert old in SOURCE, old
    return SOURCE.replace(old, new, count)


CASES = {
    "unbalanced_open": (SOURCE.rstrip().rstrip(")"), "unbalanced parentheses", 1),
    "unbalanced_close": (SOURCE + ")\n", "unexpected ')'", None),
    "unknown_block": (
        _break("(:obj_of_interest", "(:objects_of_interest"),
        "unknown block ':objects_of_interest'",
        "(:objects_of_interest",
    ),
    "unknown_predicate": (
        _break("(Open wooden_cabinet_1_middle_region)", "(Opened wooden_cabinet_1_middle_region)"),
        "unknown predicate 'Opened'",
        "(Opened",
    ),
    "undeclared_object": (
        _break("(Open wooden_cabinet_1_middle_region)", "(Open wooden_cabinet_9_middle_region)"),
        "undeclared 'wooden_cabinet_9_middle_region'",
        "wooden_cabinet_9",
    ),
    "non_numeric_range": (
        _break("(0.04 -0.03 0.060000000000000005 -0.01)", "(0.04 abc 0.060000000000000005 -0.01)"),
        "must be a number, found 'abc'",
        "abc",
    ),
    "empty_goal": (_break("(And (Open wooden_cabinet_1_middle_region))", ""), "empty goal", "(:goal"),
    "wrong_arity": (
        _break("(Open wooden_cabinet_1_middle_region)", "(Open wooden_cabinet_1_middle_region plate_1)"),
        "Open takes 1 argument",
        "(Open wooden",
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_malformed_input_names_file_line_and_problem(case: str, tmp_path: Path) -> None:
    text, problem, where = CASES[case]
    path = tmp_path / f"{case}.bddl"
    path.write_text(text)
    with pytest.raises(BDDLError) as info:
        parse_file(path)
    err = info.value
    assert problem in str(err)
    assert str(path) in str(err)
    if isinstance(where, str):
        assert err.line == _line_of(text, where)
    elif isinstance(where, int):
        assert err.line == where
    assert f"{path}, line {err.line}: " in str(err)
    assert "\n" not in str(err)


def test_missing_file() -> None:
    with pytest.raises(BDDLError, match="file not found"):
        parse_file("/nonexistent/task.bddl")


def test_bddl_error_is_a_value_error() -> None:
    with pytest.raises(ValueError):
        parse("(define (problem x)")
