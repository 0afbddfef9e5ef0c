"""The job runner: the same results in this process and in worker processes; events before results."""

from __future__ import annotations

from pathlib import Path

import pytest

from libero_data.errors import ExecutorError
from libero_data.runtime.jobs import JobPlacement, JobRunner, WorkerCache
from tests.runtime.jobs_for_tests import count_and_report, fail_on_three


@pytest.mark.parametrize("workers", [1, 2])
def test_results_events_files_and_caches(workers: int, tmp_path: Path) -> None:
    shared = tmp_path / "shared.txt"
    shared.write_text("x" * 10)
    events: list[tuple[int, int]] = []
    seen: dict[int, dict[str, int]] = {}
    with JobRunner(JobPlacement("local", workers), tmp_path) as runner:
        for i, result in runner.run(count_and_report, [5, 1, 2, 3], shared=shared, on_event=events.append):
            # Every event of a job has reached the driver before its result.
            assert sum(1 for n, _ in events if n == result["n"]) == result["n"]
            seen[i] = result
        pids = runner.worker_pids()
    assert sorted(seen) == [0, 1, 2, 3] and [seen[i]["n"] for i in range(4)] == [5, 1, 2, 3]
    assert sorted(events) == sorted((n, i) for n in (5, 1, 2, 3) for i in range(n))
    assert all(r["shared"] == 10 for r in seen.values())
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["1.txt", "2.txt", "3.txt", "5.txt"]
    # A worker's cache outlives its jobs: four jobs, at most `workers` (or one) builds.
    builds = {r["pid"] for r in seen.values()}
    assert sum(r["uses"] for r in seen.values() if r["uses"] == 1) == len(builds)
    assert len(builds) <= workers
    assert len(pids) == (0 if workers == 1 else workers)


def test_a_failing_job_raises_in_the_driver(tmp_path: Path) -> None:
    with (
        JobRunner(JobPlacement("local", 2), tmp_path) as runner,
        pytest.raises(ArithmeticError, match="job 3"),
    ):
        list(runner.run(fail_on_three, [1, 2, 3, 4]))


def test_runs_in_one_runner_keep_their_workers(tmp_path: Path) -> None:
    with JobRunner(JobPlacement("local", 1), tmp_path) as runner:
        first = [r for _, r in runner.run(count_and_report, [1, 2])]
        second = [r for _, r in runner.run(count_and_report, [3])]
    assert {r["pid"] for r in first} == {r["pid"] for r in second}
    assert second[0]["uses"] == 3  # the third job of the same worker, same cached value


def test_executor_choices_are_checked() -> None:
    with pytest.raises(ExecutorError, match="choose local or ray") as bad:
        JobPlacement("dask", 2)
    assert bad.value.field == "executor"
    with pytest.raises(ExecutorError) as lonely:
        JobPlacement("local", 2, ray_address="auto")
    assert lonely.value.field == "ray_address"
    with pytest.raises(ExecutorError, match="1 \\(this process\\) or more") as none:
        JobPlacement("local", 0)
    assert none.value.field == "workers"
    assert JobPlacement("local", 1).in_process and JobPlacement().in_process  # one process: this one
    assert not JobPlacement("local", 3).in_process and not JobPlacement("ray", 1).in_process


def test_worker_cache_rebuilds_on_a_new_key_and_closes_the_old_value() -> None:
    closed: list[str] = []
    cache = WorkerCache()
    a = cache.get("env", 1, lambda: "a", close=closed.append)
    assert cache.get("env", 1, lambda: "other") == a
    assert cache.get("env", 2, lambda: "b", close=closed.append) == "b"
    assert closed == ["a"]
    cache.close()
    assert closed == ["a", "b"]
