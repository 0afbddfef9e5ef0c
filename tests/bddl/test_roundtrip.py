from __future__ import annotations

import pytest

from libero_data.bddl import And, Atom, Not, Or, parse, parse_file, write
from libero_data.tasks import SUITE_NAMES, get_suite

ALL_TASKS = [t for name in SUITE_NAMES[:5] for t in get_suite(name).tasks]


def test_there_are_130_shipped_tasks() -> None:
    assert len(ALL_TASKS) == 130
    assert len({t.bddl_path for t in ALL_TASKS}) == 130


@pytest.mark.parametrize("task", ALL_TASKS, ids=lambda t: t.id)
def test_every_shipped_bddl_round_trips(task) -> None:
    problem = parse_file(task.bddl_path)
    assert problem.goal_atoms(), "every shipped task has a goal"
    again = parse(write(problem), source="written")
    assert again == problem
    # Writing is a fixed point: the text of a written problem is stable.
    assert write(again) == write(problem)


def test_model_fields_of_a_known_task() -> None:
    problem = parse_file(get_suite("libero_goal").task(0).bddl_path)
    assert problem.problem == "LIBERO_Tabletop_Manipulation"
    assert problem.language == "Open the middle layer of the drawer"
    assert problem.goal == And((Atom("Open", ("wooden_cabinet_1_middle_region",)),))
    assert {o.category for o in problem.fixtures} >= {"table", "wooden_cabinet"}
    region = problem.region("main_table_plate_region")
    assert region.target == "main_table" and len(region.ranges) == 1
    assert region.ranges[0][0] < region.ranges[0][2]


def test_nested_or_and_not_round_trip() -> None:
    text = write(parse_file(get_suite("libero_object").task(0).bddl_path))
    a, b = "alphabet_soup_1", "basket_1_contain_region"
    nested = text.replace(
        f"(And (In {a} {b}))",
        f"(And (Or (In {a} {b}) (Not (On {a} {b}))) (In {a} {b}))",
    )
    assert nested != text
    problem = parse(nested)
    assert isinstance(problem.goal, And)
    first = problem.goal.terms[0]
    assert isinstance(first, Or) and isinstance(first.terms[1], Not)
    assert parse(write(problem)) == problem


def test_objects_of_one_category_are_written_on_one_line_which_libero_keeps(tmp_path) -> None:
    from libero.libero.envs.bddl_utils import robosuite_parse_problem

    problem = parse_file(get_suite("libero_spatial").task(8).bddl_path)  # two black bowls
    text = write(problem)
    assert "akita_black_bowl_1 akita_black_bowl_2 - akita_black_bowl" in text
    path = tmp_path / "written.bddl"
    path.write_text(text)
    parsed = robosuite_parse_problem(str(path))  # LIBERO's own parser keeps a category's last line
    assert sorted(parsed["objects"]["akita_black_bowl"]) == ["akita_black_bowl_1", "akita_black_bowl_2"]
