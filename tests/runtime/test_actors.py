"""The actor pool: objects kept by workers, method calls sent to several at once, errors and deaths
reported in the driver."""

from __future__ import annotations

from pathlib import Path

import pytest

from libero_data.errors import ExecutorError
from libero_data.runtime.actors import ActorPool, RemoteTraceback
from libero_data.runtime.jobs import JobPlacement
from tests.runtime.jobs_for_tests import make_counter


@pytest.mark.parametrize("workers", [1, 2])
def test_actors_keep_their_state_between_calls(workers: int, tmp_path: Path) -> None:
    with ActorPool(JobPlacement("local", workers), tmp_path, make_counter) as pool:
        assert pool.size == workers  # one: this process
        everyone = range(pool.size)
        first = pool.call({i: ("add", (i + 1,)) for i in everyone})
        second = pool.call({i: ("add", (10,)) for i in everyone})
        pids = pool.worker_pids()
    assert [second[i]["total"] for i in everyone] == [i + 11 for i in everyone]
    assert all(first[i]["pid"] == second[i]["pid"] for i in everyone)
    in_process = workers == 1
    assert len(set(pids)) == (0 if in_process else workers)
    assert all(first[i]["pid"] in pids for i in everyone) or in_process
    assert len(list((tmp_path / "out").iterdir())) == 2 * len(everyone)


def test_an_actors_exception_is_raised_in_the_driver_with_its_traceback(tmp_path: Path) -> None:
    with ActorPool(JobPlacement("local", 1), tmp_path, make_counter) as pool:
        with pytest.raises(ArithmeticError, match="asked to fail") as raised:
            pool.call({0: ("fail", ())})
        assert isinstance(raised.value.__cause__, RemoteTraceback)
        assert "in actor 0" in str(raised.value.__cause__)
        assert pool.call({0: ("add", (2,))})[0]["total"] == 2  # the actor goes on


def test_a_worker_that_dies_is_named(tmp_path: Path) -> None:
    died = r"simulation worker 1 \(process \d+\) died with exit code 3"
    with (
        ActorPool(JobPlacement("local", 2), tmp_path, make_counter) as pool,
        pytest.raises(ExecutorError, match=died),
    ):
        pool.call({0: ("add", (1,)), 1: ("die", ())})


@pytest.mark.xdist_group("ray")
def test_ray_actors_keep_state_and_send_their_files_back(tmp_path: Path) -> None:
    with ActorPool(JobPlacement("ray", 2), tmp_path, make_counter) as pool:
        assert pool.size == 2
        pool.call({0: ("add", (1,)), 1: ("add", (2,))})
        again = pool.call({0: ("add", (1,)), 1: ("add", (2,))})
    assert [again[0]["total"], again[1]["total"]] == [2, 4]
    # Ray actors write in scratch folders; what they ship lands under the pool's root.
    written = sorted(p.read_text() for p in (tmp_path / "out").iterdir())
    assert written == ["1", "2", "2", "4"]


@pytest.mark.parametrize("workers", [1, 2])
def test_calls_in_flight_are_answered_in_order_and_a_failure_can_be_drained(
    workers: int, tmp_path: Path
) -> None:
    with ActorPool(JobPlacement("local", workers), tmp_path, make_counter) as pool:
        everyone = list(range(pool.size))
        pool.submit({i: ("add", (1,)) for i in everyone})
        pool.submit({i: ("add", (10,)) for i in everyone})  # two calls out per actor
        first, second = pool.collect(everyone), pool.collect(everyone)
        assert [first[i]["total"] for i in everyone] == [1] * workers
        assert [second[i]["total"] for i in everyone] == [11] * workers
        with pytest.raises(RuntimeError, match="no answer due"):
            pool.collect([0])
        pool.submit({0: ("fail", ())})
        pool.submit({0: ("add", (100,))})
        pool.drain()  # the failure and the answer after it are read and dropped
        assert pool.call({0: ("add", (1000,))})[0]["total"] == 1111
