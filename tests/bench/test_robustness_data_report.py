"""``benchmarks/robustness_data_report.py`` on synthetic sweeps: it pools the tasks swept so far,
names those not yet swept, and leaves out a kind a task has no variant of (no simulation)."""

from __future__ import annotations

import json
from pathlib import Path

from benchmarks.robustness_data_report import NOT_TRAINED, TRAINED, summary
from libero_bench.robustness.cells import Cell, table

TASK = "pick_up_the_alphabet_soup_and_place_it_in_the_basket"
KINDS = tuple(k for k in (*TRAINED, *NOT_TRAINED) if k != "swap")  # libero_object/0 has no swap
LEVELS = (1, 3, 5)
N = 10


def _sweep(
    folder: Path,
    wins: int,
    perturbed_wins: int,
    kinds: tuple[str, ...] = KINDS,
    levels: tuple[int, ...] = LEVELS,
) -> None:
    cells = [Cell(TASK, "", 0, TASK, "pick", "x.bddl")]
    cells += [Cell(TASK, k, lv, f"{TASK}__{k}_l{lv}", "pick", "x.bddl") for k in kinds for lv in levels]
    outcomes = {c.name: [i < (perturbed_wins if c.kind else wins) for i in range(N)] for c in cells}
    folder.mkdir(parents=True)
    report = {
        "policy": str(folder),
        "policy_name": folder.name,
        "request": {"tasks": [TASK], "kinds": list(kinds), "levels": list(levels), "rollouts": N},
        "table": table(cells, outcomes, kinds, levels),
        "heldout_seeds": {TASK: list(range(100, 100 + N))},
        "outcomes": outcomes,
    }
    (folder / "robustness.json").write_text(json.dumps(report))


def test_the_report_pools_what_was_swept(tmp_path: Path) -> None:
    _sweep(tmp_path / "sweeps" / "single-object-0", wins=8, perturbed_wins=2)
    _sweep(tmp_path / "sweeps" / "mixed-object-0", wins=8, perturbed_wins=7)
    text = summary(tmp_path)
    assert "Tasks swept: object-0 (not yet: spatial-8)" in text
    assert "| trained kinds, level 3 | +50% |" in text
    assert "kinds not trained on (layout, distractors, language), level 5 | +50% |" in text
    assert "**met** (+50%" in text
    assert "Room A left at level 3 (B − A if B succeeded in every trained kind's cell): object-0 +80%" in text
    task = tmp_path / "object-0"
    assert (task / "compare.json").is_file() and (task / "compare.png").is_file()
    assert not (tmp_path / "pooled").exists()  # one task: its own comparison is the pooled one


def test_more_draws_of_the_level3_cells_are_reported_alone_and_pooled(tmp_path: Path) -> None:
    _sweep(tmp_path / "sweeps" / "single-object-0", wins=8, perturbed_wins=2)
    _sweep(tmp_path / "sweeps" / "mixed-object-0", wins=8, perturbed_wins=7)
    _sweep(tmp_path / "sweeps" / "single-object-0-draw1", wins=8, perturbed_wins=2)
    _sweep(tmp_path / "sweeps" / "mixed-object-0-draw1", wins=8, perturbed_wins=4)
    _sweep(tmp_path / "sweeps" / "single-object-0-draw2", wins=8, perturbed_wins=2)  # its B not swept yet
    text = summary(tmp_path)
    assert "| trained kinds, level 3 | +50% |" in text  # the main sweep's figure is unchanged
    assert "| object-0, draw 0 | +50% |" in text
    assert "| object-0, draw 1 | +20% |" in text
    assert "| object-0, draws 0-1 pooled | +35% |" in text
    assert "draw 2" not in text
    assert (tmp_path / "object-0" / "draws" / "compare.json").is_file()


def test_levers_are_compared_with_both_runs_of_their_task(tmp_path: Path) -> None:
    sweeps = tmp_path / "sweeps"
    _sweep(sweeps / "single-object-0", wins=8, perturbed_wins=2)
    _sweep(sweeps / "mixed-object-0", wins=8, perturbed_wins=5)
    _sweep(sweeps / "mixed-long-object-0", wins=9, perturbed_wins=7, kinds=TRAINED, levels=(3,))
    _sweep(sweeps / "mixed-aug-spatial-8", wins=9, perturbed_wins=7, kinds=TRAINED, levels=(3,))  # no A, B
    text = summary(tmp_path)
    assert "| mixed-long, object-0: B trained 16 epochs more" in text
    assert "| 8/10 → 9/10 (+10%, p=1) | +50% [" in text  # against A: 2/10 -> 7/10 in every trained kind
    assert "] | +20% [" in text  # against B: 5/10 -> 7/10
    assert "spatial-8" not in text.split("Why the goal was missed")[1]
    assert "mixed-aug against single-aug" not in text  # one of the two only
    _sweep(sweeps / "single-aug-object-0", wins=10, perturbed_wins=4, kinds=TRAINED, levels=(3,))
    _sweep(sweeps / "mixed-aug-object-0", wins=6, perturbed_wins=5, kinds=TRAINED, levels=(3,))
    text = summary(tmp_path)
    assert "| object-0 | 10/10 → 6/10 (p=0.12) | +10% [" in text
    assert (tmp_path / "object-0" / "levers" / "mixed-long" / "compare.md").is_file()
    # the mixed-aug against single-aug row's per-kind comparison
    assert (tmp_path / "object-0" / "levers" / "mixed-aug-vs-single-aug" / "compare.md").is_file()
    assert "mixed-more against single-aug" not in text
    _sweep(sweeps / "mixed-more-object-0", wins=7, perturbed_wins=8, kinds=TRAINED, levels=(3,))
    text = summary(tmp_path)
    assert "| mixed-more − single-aug, trained kinds, level 3 |" in text
    assert "| object-0 | 10/10 → 7/10 (p=0.25) | +40% [" in text  # 4/10 -> 8/10 in every trained kind
    assert (tmp_path / "object-0" / "levers" / "mixed-more-vs-single-aug" / "compare.md").is_file()
