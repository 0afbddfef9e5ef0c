"""Two methods compared over several seeds (libero_bench.analysis.seeds), on hand-made run folders:
paired by seed and start, pooled, and number for number the two-run comparison with one seed."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from libero_bench.analysis.compare import compare_runs
from libero_bench.analysis.seeds import compare_seeds, seeds_markdown
from libero_data.errors import RunError
from tests.bench.fake_runs import TASKS, fake_run

LEARN = [[1] * 10, [1] * 10]


def _seql(root: Path, seed: int, kept: int) -> Path:
    """SeqL keeps task 0 from ``kept`` of its 10 starts after task 1."""
    return fake_run(
        root / f"seql-s{seed}", algo="seql", seed=seed, learn=LEARN, after=[1] * kept + [0] * (10 - kept)
    )


def _er(root: Path, seed: int) -> Path:
    return fake_run(root / f"er-s{seed}", algo="er", seed=seed, learn=LEARN, after=[1] * 10)


def test_one_seed_is_the_two_run_comparison_number_for_number(tmp_path: Path) -> None:
    a, b = _seql(tmp_path, 0, 4), _er(tmp_path, 0)
    pooled, single = compare_seeds([a], [b]), compare_runs(a, b)
    assert pooled["seeds"] == [0]
    assert pooled["stored"]["all"] == single["stored"]["all"]
    for name, row in single["stored"]["difference"]["metrics"].items():
        mine = pooled["stored"]["difference"]["metrics"][name]
        for key in ("a", "b", "difference", "low", "high", "p_value", "significant"):
            assert mine[key] == row[key], (name, key)


def test_seeds_pool_their_starts_and_their_differences(tmp_path: Path) -> None:
    seql = [_seql(tmp_path, 0, 4), _seql(tmp_path, 1, 8)]  # NBT 0.6 and 0.2
    er = [_er(tmp_path, 0), _er(tmp_path, 1)]  # NBT 0
    result = compare_seeds(list(reversed(seql)), er)  # paired by seed, not by order
    assert result["seeds"] == [0, 1]
    task0 = result["stored"]["tasks"][TASKS[0]]
    assert (task0["n"], task0["a"]["successes"], task0["b"]["successes"], task0["only_b"]) == (20, 12, 20, 8)
    assert result["stored"]["by_seed"]["0"]["only_b"] == 6 and result["stored"]["by_seed"]["1"]["only_b"] == 2
    nbt = result["stored"]["difference"]["metrics"]["nbt"]
    assert nbt["difference"] == pytest.approx(0.4) and nbt["by_seed"] == {
        "0": pytest.approx(0.6),
        "1": pytest.approx(0.2),
    }
    # The interval counts the spread between the seeds; the stratified test pools their evidence.
    assert nbt["low"] <= 0.25 and nbt["high"] >= 0.55
    alone = [
        compare_runs(s, e)["stored"]["difference"]["metrics"]["nbt"]["p_value"]
        for s, e in zip(seql, er, strict=True)
    ]
    assert nbt["p_value"] < min(alone) and nbt["significant"]
    text = seeds_markdown(result)
    assert "seeds 0, 1" in text and "| stored | NBT | 0.40 | 0.00 | +0.40 [" in text
    assert "0: +0.60, 1: +0.20" in text


def test_seeds_must_match_one_to_one(tmp_path: Path) -> None:
    seql0, seql1, er0 = _seql(tmp_path, 0, 4), _seql(tmp_path, 1, 8), _er(tmp_path, 0)
    with pytest.raises(RunError, match="seed 1 has a run of only one method"):
        compare_seeds([seql0, seql1], [er0])
    twin = fake_run(tmp_path / "twin", algo="seql", seed=0, learn=LEARN, after=[1] * 10)
    with pytest.raises(RunError, match="are both seed 0 of one method"):
        compare_seeds([seql0, twin], [er0])


def test_the_command_pairs_two_methods_seeds_and_refuses_one_method(tmp_path: Path) -> None:
    runs = [_seql(tmp_path, 0, 4), _seql(tmp_path, 1, 8), _er(tmp_path, 0), _er(tmp_path, 1)]
    command = [sys.executable, "-m", "libero_bench.cli", "compare"]
    done = subprocess.run(
        [*command, *map(str, runs), "--out", str(tmp_path / "cmp")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "seeds 0, 1, paired by seed and start" in done.stdout
    assert "stored starts, NBT: A 0.40, B 0.00, A − B +0.40 [" in done.stdout
    written = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    assert written["a"]["paths"] == ["../seql-s0", "../seql-s1"] and written["seeds"] == [0, 1]
    refused = subprocess.run(
        [*command, *map(str, runs[:2]), str(runs[0])], capture_output=True, text=True, timeout=120
    )
    assert refused.returncode != 0 and "Traceback" not in refused.stderr
    assert "form 1 method(s)" in refused.stderr + refused.stdout
