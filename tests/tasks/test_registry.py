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
