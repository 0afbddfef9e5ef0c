"""Two robustness sweeps compared start for start: pairing, McNemar, intervals, refusals, plots
(synthetic sweep reports, no simulation)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from libero_bench.robustness.cells import Cell, table
from libero_bench.robustness.paired import compare_sweeps, mean_difference, write_comparison
from libero_data.errors import RunError

TASK = "pick_up_the_alphabet_soup_and_place_it_in_the_basket"
KINDS = ("camera", "lighting")
LEVELS = (1, 3)
N = 10


def _cells() -> list[Cell]:
    cells = [Cell(TASK, "", 0, TASK, "pick", "x.bddl")]
    cells += [Cell(TASK, k, lv, f"{TASK}__{k}_l{lv}", "pick", "x.bddl") for k in KINDS for lv in LEVELS]
    return cells


def _sweep(folder: Path, wins: dict[str, int], seeds: list[int] | None = None) -> Path:
    """A sweep report whose cell ``name`` succeeds on its first ``wins[name]`` starts."""
    cells = _cells()
    outcomes = {c.name: [i < wins.get(c.name, 0) for i in range(N)] for c in cells}
    summary = {
        "policy": str(folder),
        "policy_name": folder.name,
        "request": {"tasks": [TASK], "kinds": list(KINDS), "levels": list(LEVELS), "rollouts": N},
        "table": table(cells, outcomes, KINDS, LEVELS),
        "heldout_seeds": {TASK: seeds or list(range(100, 100 + N))},
        "outcomes": outcomes,
    }
    folder.mkdir(parents=True)
    (folder / "robustness.json").write_text(json.dumps(summary))
    return folder


def test_pairs_give_mcnemar_and_paired_intervals(tmp_path: Path) -> None:
    cam3 = f"{TASK}__camera_l3"
    a = _sweep(tmp_path / "a", {TASK: 8, cam3: 1, f"{TASK}__lighting_l3": 5})
    b = _sweep(tmp_path / "b", {TASK: 8, cam3: 9, f"{TASK}__lighting_l3": 5})
    result = compare_sweeps(a, b)
    cell = result["grid"]["camera"]["3"]
    assert (cell["a"]["successes"], cell["b"]["successes"], cell["only_b"], cell["only_a"]) == (1, 9, 8, 0)
    assert cell["difference"] == pytest.approx(0.8)
    assert cell["significant"] and cell["p_value"] == pytest.approx(2 / 2**8)
    assert cell["diff_low"] >= 0.5 and cell["diff_high"] <= 1.0
    same = result["grid"]["lighting"]["3"]  # identical outcomes: no difference, no spread
    assert same["difference"] == 0 and same["diff_low"] == same["diff_high"] == 0 and not same["significant"]
    assert result["grid"]["camera"]["0"]["n"] == N  # the unperturbed task heads every row
    assert result["per_kind"]["camera"]["n"] == 2 * N
    mean = mean_difference(result, KINDS, 3)
    assert mean["difference"] == pytest.approx(0.4)
    assert 0.2 < mean["low"] < 0.4 < mean["high"] <= 0.5 + 1e-9
    paths = write_comparison(result, tmp_path / "out")
    assert [p.name for p in paths] == ["compare.json", "compare.md", "compare.png"]
    assert paths[2].stat().st_size > 10_000
    text = paths[1].read_text()
    assert "10% → 90% (+80%" in text and "*" in text
    with pytest.raises(RunError, match="no texture cells of level 3"):
        mean_difference(result, ("texture",), 3)


def test_sweeps_that_cannot_be_paired_are_refused(tmp_path: Path) -> None:
    a = _sweep(tmp_path / "a", {TASK: 5})
    other = _sweep(tmp_path / "b", {TASK: 5}, seeds=list(range(200, 200 + N)))
    with pytest.raises(RunError, match="different held-out placements"):
        compare_sweeps(a, other)
    old = _sweep(tmp_path / "old", {TASK: 5})
    summary = json.loads((old / "robustness.json").read_text())
    del summary["outcomes"]
    (old / "robustness.json").write_text(json.dumps(summary))
    with pytest.raises(RunError, match="before sweeps recorded each rollout's outcome"):
        compare_sweeps(a, old)


def test_bootstrap_is_seeded(tmp_path: Path) -> None:
    a = _sweep(tmp_path / "a", {f"{TASK}__camera_l1": 3})
    b = _sweep(tmp_path / "b", {f"{TASK}__camera_l1": 6})
    first, second = compare_sweeps(a, b), compare_sweeps(a, b)
    assert first["grid"]["camera"]["1"] == second["grid"]["camera"]["1"]
    assert np.isfinite(first["grid"]["camera"]["1"]["diff_low"])


def test_sweeps_of_several_tasks_pool(tmp_path: Path) -> None:
    cam1 = f"{TASK}__camera_l1"
    a1, b1 = _sweep(tmp_path / "a1", {cam1: 2}), _sweep(tmp_path / "b1", {cam1: 7})
    a2, b2 = _sweep(tmp_path / "a2", {cam1: 4}), _sweep(tmp_path / "b2", {cam1: 4})
    pooled = compare_sweeps([a1, a2], [b1, b2])
    cell = pooled["grid"]["camera"]["1"]
    assert (cell["n"], cell["a"]["successes"], cell["b"]["successes"]) == (2 * N, 6, 11)
    assert pooled["a"]["policy_name"] == "a1, a2"
    with pytest.raises(RunError, match="as many sweeps"):
        compare_sweeps([a1, a2], [b1])


def test_sweeps_of_other_variant_seeds_are_not_paired(tmp_path: Path) -> None:
    a = _sweep(tmp_path / "a", {TASK: 5})
    b = _sweep(tmp_path / "b", {TASK: 5})
    summary = json.loads((b / "robustness.json").read_text())
    summary["request"]["seed"] = 1
    (b / "robustness.json").write_text(json.dumps(summary))
    with pytest.raises(RunError, match="different seeds"):
        compare_sweeps(a, b)


def test_a_sweep_of_some_kinds_draws_the_full_sweeps_variants(tmp_path: Path) -> None:
    """A cell's variant depends on its kind, level and seed, not on which other kinds are swept: a
    level-3 sweep of the trained kinds can be paired with those cells of a full sweep."""
    from libero_bench.robustness.cells import SweepRequest, make_cells
    from libero_data.perturb.levels import KINDS

    def variants(kinds: tuple[str, ...], folder: Path) -> dict[str, str]:
        request = SweepRequest(tasks=("libero_object/0",), kinds=kinds, levels=(3,), rollouts=1)
        cells = make_cells(request, folder)
        return {c.name: Path(c.bddl).read_text() for c in cells if not c.reason}

    full = variants(KINDS, tmp_path / "full")
    some = variants(("noise", "camera"), tmp_path / "some")
    assert len(some) == 3  # the source task and the two variants
    assert all(full[name] == text for name, text in some.items())
