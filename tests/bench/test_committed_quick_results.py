"""The committed ``quick`` results (``benchmarks/results/quick/``) are what today's preset makes
and what benchmarks/RESULTS.md states of them.

Reads the committed files only (no training, no simulation): a change of the ``quick`` preset
or of the quick policy size that is not followed by new results (``benchmarks/quick.sh``), and a
single-task result other than RESULTS states must not land; nor may a lifelong pair
(SeqL and ER) whose two runs differ in anything but the algorithm, or whose report and paired
comparison are missing.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from libero_bench.runs.folder import STARTS, RunResults
from libero_bench.runs.intervals import final_rates
from libero_bench.train.presets import get_preset

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "quick"
SINGLE = ("single-0", "single-1", "single-2")
LIFELONG = ("seql", "er")
TARGET = 0.8
#: The lifelong pair predates two changes: its data came from the expert before its faster version,
#: and its evaluations were cut at 300 steps (the quick preset's limit then) instead of the suite's
#: 280. Its claim, ER forgetting less than SeqL on the same data, does not rest on either;
#: `benchmarks/quick.sh WORK_DIR lifelong` makes it again with today's (~4 h on 2 cores).
LIFELONG_PRESET = {"eval_max_steps": 300}


def _run(name: str) -> tuple[dict[str, Any], RunResults]:
    folder = RESULTS / "runs" / name
    return (
        json.loads((folder / "config.json").read_text()),
        RunResults.from_dict(json.loads((folder / "results.json").read_text())),
    )


@pytest.mark.parametrize("name", SINGLE + LIFELONG)
def test_each_committed_run_was_made_with_todays_quick_preset_and_policy(name: str) -> None:
    from libero_bench.policies import policy_config

    preset = get_preset("quick")
    config, results = _run(name)
    assert results.complete, f"{name} did not finish"
    made_with = {**preset.to_dict(), **(LIFELONG_PRESET if name in LIFELONG else {})}
    assert config["preset"] == made_with, (
        f"{name} was made with another quick preset: run benchmarks/quick.sh again"
    )
    policy = policy_config(
        config["policy"], preset.policy_size, image_size=preset.image_size, window=preset.window
    )
    assert config["policy_config"] == policy.to_dict(), f"{name} was made with another quick policy size"
    # demonstrations from the sampler only: the stored evaluation starts are unseen
    for task in config["evaluation"]["training_starts"].values():
        assert task["demos_from_stored_inits"] == 0 and task["stored_eval_starts_trained_on"] == []
        assert task["demos_from_sampler"] == 100
    for start in STARTS:  # every task evaluated from 20 starts of each kind after the last
        final = final_rates(results, len(config["tasks"]), start)  # as `libero-bench report` gives it
        assert [rate.n for rate in final] == [20] * len(config["tasks"])


#: What RESULTS states each libero_object task trained alone reached, from stored
#: starts and held-out placements, with today's demonstrations and the suite's step limit.
#: libero_object/0 from stored starts (14/20) is under the 80% target that the runs made with
#: the slower expert's data met (19/20): 4 of its 6 failures never lifted the soup, 2 dropped it;
#: none was near the limit's doing (benchmarks/results/quick/single-task/failures.md).
STATED = {"single-0": (14, 18), "single-1": (20, 18), "single-2": (19, 20)}


@pytest.mark.parametrize("position", [0, 1, 2])
def test_each_libero_object_task_trained_alone_reached_what_results_states(position: int) -> None:
    name = f"single-{position}"
    config, results = _run(name)
    assert [t["suite_index"] for t in config["tasks"]] == [position]
    finals = []
    for start in STARTS:
        (final,) = final_rates(results, 1, start)
        assert final.n == 20
        finals.append(final.successes)
    assert tuple(finals) == STATED[name], f"{name}: {finals}/20; RESULTS states {STATED[name]}"
    stored, heldout = STATED[name]
    # RESULTS states them (the docs link there, and retell no figure): in the section's table
    # (stored, held out) and in the targets' table at the top
    stated = (RESULTS.parents[1] / "RESULTS.md").read_text()
    (row,) = [r for r in stated.splitlines() if r.startswith(f"| libero_object/{position} (`runs/{name}`) |")]
    cells = [cell.strip() for cell in row.split("|")]
    assert cells[2].startswith(f"**{stored}/20**") and cells[3].startswith(f"**{heldout}/20**"), row
    assert f"task {position} {stored}/20 and {heldout}/20" in stated
    meets = all(n >= TARGET * 20 for n in STATED[name])
    assert meets or name == "single-0", f"{name} under the target: say so in RESULTS and here"
    _assert_cut_at_the_suites_limit(results, "libero_object")


def _assert_cut_at_the_suites_limit(results: RunResults, suite: str) -> None:
    """Every rollout within its suite's step limit, and every failure cut at it."""
    from libero_data.tasks.horizons import SUITE_LIMITS

    limit = SUITE_LIMITS[suite]
    assert all(r["steps"] <= limit for r in results.rollouts)
    assert all(r["steps"] == limit for r in results.rollouts if not r["success"])


def test_the_lifelong_pair_shares_data_tasks_and_seed() -> None:
    (seql, _), (er, _) = _run("seql"), _run("er")
    assert (seql["algo"], er["algo"]) == ("seql", "er")
    for key in ("data", "dataset", "tasks", "seed", "preset", "policy_config"):
        assert seql[key] == er[key], key
    assert [t["suite_index"] for t in seql["tasks"]] == [0, 1, 2]
    report = json.loads((RESULTS / "lifelong" / "report.json").read_text())
    assert sorted(g["algo"] for g in report["groups"]) == ["er", "seql"]
    for group in report["groups"]:  # forgetting with its interval, from both kinds of start
        for start in STARTS:
            nbt = group[start]["nbt"]
            assert nbt["low"] <= nbt["mean"] <= nbt["high"]
    assert (RESULTS / "lifelong" / "compare.md").is_file()
    compare = json.loads((RESULTS / "lifelong" / "compare.json").read_text())
    assert (compare["a"]["label"], compare["b"]["label"]) == ("seql + resnet_t", "er + resnet_t")
    for start in STARTS:  # the committed claim: SeqL forgets more than ER, by a tested margin
        nbt = compare[start]["difference"]["metrics"]["nbt"]
        assert nbt["significant"] and nbt["low"] > 0, (start, nbt)


def test_the_committed_comparison_is_what_compare_makes_from_the_committed_runs() -> None:
    from libero_bench.analysis.compare import compare_runs

    made = compare_runs(RESULTS / "runs" / "seql", RESULTS / "runs" / "er")
    committed = json.loads((RESULTS / "lifelong" / "compare.json").read_text())
    for start in STARTS:  # McNemar per task, seeded bootstrap intervals and permutation p
        _assert_close(json.loads(json.dumps(made[start])), committed[start], start)


def _assert_close(made: Any, committed: Any, where: str) -> None:
    """Equal, floats to 1e-9: the summation order of another CPU's SIMD kernel may move last bits."""
    if isinstance(committed, dict):
        assert made.keys() == committed.keys(), where
        for key in committed:
            _assert_close(made[key], committed[key], f"{where}.{key}")
    elif isinstance(committed, float):
        assert made == pytest.approx(committed, rel=1e-9, abs=1e-12), where
    else:
        assert made == committed, where


#: The quick recipe on one task of each other suite, drawn before any training
#: (benchmarks/quick_suites.sh), evaluated at each suite's step limit.
SUITE_RUNS = {
    "single-spatial-8": "libero_spatial/8",
    "single-goal-1": "libero_goal/1",
    "single-long-0": "libero_10/0",
}


@pytest.mark.parametrize("name", sorted(SUITE_RUNS))
def test_each_suite_run_is_the_quick_recipe_at_its_suites_step_limit(name: str) -> None:
    config, results = _run(name)
    assert results.complete, f"{name} did not finish"
    assert config["preset"] == get_preset("quick").to_dict()
    suite, index = SUITE_RUNS[name].split("/")
    assert config["dataset"]["suite"] == suite and [t["suite_index"] for t in config["tasks"]] == [int(index)]
    (task,) = config["evaluation"]["training_starts"].values()
    assert task["demos_from_stored_inits"] == 0 and task["demos_from_sampler"] == 100
    for start in STARTS:
        (final,) = final_rates(results, 1, start)
        assert final.n == 20
    _assert_cut_at_the_suites_limit(results, suite)
    report = json.loads((RESULTS / "suites" / "report.json").read_text())
    assert len(report["groups"]) == len(SUITE_RUNS)
