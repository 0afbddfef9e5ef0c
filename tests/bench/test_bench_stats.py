"""Numbers with their uncertainty: Wilson and bootstrap intervals in reports, and comparing two
runs with McNemar's test, on hand-made run folders (no simulation)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from libero_bench.analysis.compare import compare_runs
from libero_bench.analysis.report import summarize, write_report
from libero_bench.runs.summary import load_run
from libero_data.stats import mcnemar_exact
from tests.bench.fake_runs import TASKS, fake_run


def test_mcnemar_exact_matches_the_binomial_test() -> None:
    assert mcnemar_exact(0, 0) == 1.0
    assert mcnemar_exact(0, 6) == pytest.approx(2 * 0.5**6)
    assert mcnemar_exact(6, 0) == mcnemar_exact(0, 6)
    assert mcnemar_exact(3, 4) == 1.0
    assert mcnemar_exact(1, 9) == pytest.approx(2 * (1 + 10) / 2**10)


def test_report_gives_rates_with_n_and_intervals_from_both_kinds_of_start(tmp_path: Path) -> None:
    run = fake_run(
        tmp_path / "a",
        algo="seql",
        seed=0,
        learn=[[1] * 18 + [0] * 2, [1] * 16 + [0] * 4],
        after=[1] * 5 + [0] * 15,
        heldout=[[1] * 15 + [0] * 5, [1] * 14 + [0] * 6],
    )
    summary = write_report([run], tmp_path / "report")
    (group,) = summary["groups"]
    stored, heldout = group["stored"], group["heldout"]
    # Final success: task 0 after task 1 (5 of 20), task 1 at its kept epoch (16 of 20).
    assert [(f["successes"], f["n"]) for f in stored["final"]] == [(5, 20), (16, 20)]
    assert stored["final"][0]["low"] < 0.25 < stored["final"][0]["high"]
    # NBT: 0.9 - 0.25 = 0.65 over the first task; its interval holds it and has a width.
    assert stored["nbt"]["mean"] == pytest.approx(0.65)
    assert stored["nbt"]["low"] < 0.65 < stored["nbt"]["high"]
    assert stored["nbt"]["high"] - stored["nbt"]["low"] > 0.1
    assert heldout["fwt"]["mean"] == pytest.approx((0.75 + 0.7) / 2)
    assert heldout["fwt"]["low"] < heldout["fwt"]["mean"] < heldout["fwt"]["high"]
    text = (tmp_path / "report" / "report.md").read_text()
    assert "| seql + resnet_t |" in text and "held out" in text and "[" in text
    assert "began from 3 of the stored init states" in text  # the run says where its data began
    for name in (
        "seql-resnet-t_success_matrix.png",
        "seql-resnet-t_success_curves.png",
        "seql-resnet-t_metrics.png",
    ):
        assert (tmp_path / "report" / name).read_bytes()[:4] == b"\x89PNG"
    assert not (tmp_path / "report" / "methods_metrics.png").exists()  # one method: nothing to set beside
    # The draws are seeded: the same runs give the same interval.
    wide = summarize([load_run(run)])["groups"][0]["stored"]["nbt"]
    assert wide["high"] - wide["low"] == pytest.approx(stored["nbt"]["high"] - stored["nbt"]["low"])


def test_several_seeds_give_one_interval_over_runs_and_rollouts(tmp_path: Path) -> None:
    runs = [
        fake_run(
            tmp_path / f"s{seed}",
            algo="er",
            seed=seed,
            learn=[[1] * 20, [1] * 20],
            after=[1] * (10 + 5 * seed) + [0] * (10 - 5 * seed),
        )
        for seed in (0, 1)
    ]
    group = summarize([load_run(r) for r in runs])["groups"][0]
    assert group["seeds"] == [0, 1]
    nbt = group["stored"]["nbt"]
    assert nbt["mean"] == pytest.approx((0.5 + 0.25) / 2) and nbt["runs"] == 2
    assert nbt["interval"] == "bootstrap over runs and rollouts"
    assert nbt["low"] <= 0.25 and nbt["high"] >= 0.5


def test_compare_pairs_the_same_starts_and_tests_the_difference(tmp_path: Path) -> None:
    seql = fake_run(
        tmp_path / "seql", algo="seql", seed=0, learn=[[1] * 20, [1] * 20], after=[0] * 18 + [1] * 2
    )
    er = fake_run(tmp_path / "er", algo="er", seed=0, learn=[[1] * 20, [1] * 20], after=[1] * 20)
    result = compare_runs(seql, er)
    task0 = result["stored"]["tasks"][TASKS[0]]
    assert (task0["a"]["successes"], task0["b"]["successes"], task0["only_a"], task0["only_b"]) == (
        2,
        20,
        0,
        18,
    )
    assert task0["p_value"] == pytest.approx(2 * 0.5**18) and task0["significant"]
    task1 = result["stored"]["tasks"][TASKS[1]]
    assert task1["p_value"] == 1.0 and not task1["significant"]
    assert result["stored"]["all"]["n"] == 40 and result["heldout"] is None

    # Forgetting: SeqL lost task 0 (NBT 0.9), ER kept it (NBT 0); a paired interval of A - B.
    difference = result["stored"]["difference"]
    assert difference["paired"]
    nbt = difference["metrics"]["nbt"]
    assert (nbt["a"], nbt["b"]) == (pytest.approx(0.9), pytest.approx(0.0))
    assert 0.5 < nbt["low"] <= nbt["difference"] <= nbt["high"] <= 1.0
    assert nbt["p_value"] < 0.01 and nbt["significant"]
    fwt = difference["metrics"]["fwt"]  # both learned both tasks from every start
    assert fwt["difference"] == 0.0 and fwt["p_value"] == 1.0 and not fwt["significant"]

    # Through the command line: one line per kind of start, and the files.
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "libero_bench.cli",
            "compare",
            str(seql),
            str(er),
            "--out",
            str(tmp_path / "cmp"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "stored starts, all tasks: A 22/40, B 40/40; B succeeds more often" in done.stdout
    assert json.loads((tmp_path / "cmp" / "compare.json").read_text())["stored"]["all"]["significant"]
    assert "stored starts, NBT: A 0.90, B 0.00, A − B +0.90 [" in done.stdout
    assert "A's NBT is higher (paired permutation p ≤ 0.0005: none of 2000 random swaps" in done.stdout
    assert "McNemar" in (tmp_path / "cmp" / "compare.md").read_text()
    assert "| stored | NBT | 0.90 | 0.00 | +0.90 [" in (tmp_path / "cmp" / "compare.md").read_text()

    # The report of the two sets their FWT, NBT and AUC side by side.
    summary = write_report([seql, er], tmp_path / "report")
    assert "methods_metrics.png" in summary["files"]  # named from the report's folder
    assert summary["runs"][0]["path"] == "../seql" and summary["groups"][1]["runs"] == ["../er"]
    assert (tmp_path / "report" / "methods_metrics.png").read_bytes()[:4] == b"\x89PNG"


def test_the_nbt_difference_is_not_significant_when_both_runs_forget_alike(tmp_path: Path) -> None:
    a = fake_run(tmp_path / "a", algo="seql", seed=0, learn=[[1] * 10, [1] * 10], after=[1, 0] * 5)
    b = fake_run(tmp_path / "b", algo="er", seed=0, learn=[[1] * 10, [1] * 10], after=[0, 1] * 5)
    nbt = compare_runs(a, b)["stored"]["difference"]["metrics"]["nbt"]
    assert nbt["difference"] == 0.0 and nbt["low"] < 0 < nbt["high"]
    assert nbt["p_value"] == 1.0 and not nbt["significant"]


def test_runs_evaluated_differently_are_compared_by_independent_bootstraps(tmp_path: Path) -> None:
    a = fake_run(tmp_path / "a", algo="seql", seed=0, learn=[[1] * 20, [1] * 20], after=[0] * 20)
    b = fake_run(tmp_path / "b", algo="er", seed=0, learn=[[1] * 10, [1] * 10], after=[1] * 10)
    difference = compare_runs(a, b)["stored"]["difference"]
    nbt = difference["metrics"]["nbt"]
    assert not difference["paired"] and nbt["p_value"] is None
    assert nbt["difference"] == 1.0 and nbt["significant"]  # the interval [1, 1] excludes 0


@pytest.mark.parametrize("only_a", [4, 5, 7])
def test_the_permutation_test_of_one_success_rate_is_mcnemars(tmp_path: Path, only_a: int) -> None:
    """A one-task run's FWT is one success rate: swapping paired outcomes at random is McNemar's
    exact test, up to the error of 2000 draws."""
    learn_a = [[1] * 20, [1] * only_a + [0] * (20 - only_a)]
    a = fake_run(tmp_path / "a", algo="seql", seed=0, learn=learn_a, after=[1] * 20)
    b = fake_run(tmp_path / "b", algo="seql", seed=0, learn=[[1] * 20, [0] * 20], after=[1] * 20)
    fwt = compare_runs(a, b)["stored"]["difference"]["metrics"]["fwt"]
    assert fwt["difference"] == pytest.approx(only_a / 40)
    assert fwt["p_value"] == pytest.approx(mcnemar_exact(only_a, 0), abs=0.02)
    assert fwt["significant"] == (mcnemar_exact(only_a, 0) < 0.05)


def test_runs_evaluated_from_other_starts_are_not_paired(tmp_path: Path) -> None:
    a = fake_run(tmp_path / "a", algo="seql", seed=0, learn=[[1] * 4, [1] * 4], after=[1] * 4)
    b = fake_run(tmp_path / "b", algo="er", seed=0, learn=[[1] * 4, [1] * 4], after=[1] * 4)
    results = json.loads((b / "results.json").read_text())
    for r in results["rollouts"]:
        r["env_seed"] += 7
    (b / "results.json").write_text(json.dumps(results))
    with pytest.raises(ValueError, match="started from different states"):
        compare_runs(a, b)
    assert math.isfinite(summarize([load_run(a)])["groups"][0]["stored"]["fwt"]["mean"])


def test_the_report_states_the_step_limit_the_rollouts_had(tmp_path: Path) -> None:
    import json

    run = fake_run(tmp_path / "a", algo="seql", seed=0, learn=[[1] * 4, [1] * 4], after=[1] * 4)
    config = json.loads((run / "config.json").read_text())
    config["preset"]["eval_max_steps"] = "suite"
    config["dataset"] = {"suite": "libero_10"}
    (run / "config.json").write_text(json.dumps(config))
    summary = write_report([run], tmp_path / "report")
    assert summary["runs"][0]["step_limits"] == dict.fromkeys(TASKS, 520)
    assert "cut after 520 steps" in (tmp_path / "report" / "report.md").read_text()
