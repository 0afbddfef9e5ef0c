"""``libero-data`` from the command line: tables, scene pictures and bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest


def cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "libero_data.cli", *args], capture_output=True, text=True, cwd=cwd, timeout=300
    )


def test_tasks_lists_libero_100() -> None:
    result = cli("tasks", "--suite", "libero_100", "--json")
    assert result.returncode == 0, result.stderr
    rows = [json.loads(line) for line in result.stdout.splitlines()]
    assert len(rows) == 100
    assert [r["index"] for r in rows] == list(range(100))
    assert rows[0]["goal"].startswith("(And ")


def test_tasks_table() -> None:
    result = cli("tasks", "--suite", "libero_goal")
    assert result.returncode == 0, result.stderr
    assert "libero_goal (10 tasks)" in result.stdout
    assert "open the middle drawer of the cabinet" in result.stdout
    assert "(Open wooden_cabinet_1_middle_region)" in result.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("tasks", "--suite", "libero_gaol"), "unknown suite 'libero_gaol'"),
        (("show", "libero_goal/42"), "suite libero_goal has tasks 0..9, not 42"),
        (("show", "pick_up_the_alphabet_soup"), "unknown task 'pick_up_the_alphabet_soup'"),
        (("show", "missing.bddl"), "BDDL file missing.bddl does not exist"),
        # A field the library names, mapped to the command's option.
        (("generate", "--tasks", "0,0", "--out", "unused"), "the task list names a task twice (--tasks)"),
        (("generate", "--suite", "libero_goal", "--out", "unused", "--executor", "dask"), "(--executor)"),
        (
            ("generate", "--suite", "libero_goal", "--max-length", "0", "--out", "unused"),
            "the length bound is a positive number of steps, 'standard' or 'none', got 0 (--max-length)",
        ),
        (("generate", "--max-length", "forever", "--out", "unused"), "got 'forever' (--max-length)"),
    ],
)
def test_bad_input_is_one_sentence_and_exit_2(args: tuple[str, ...], message: str) -> None:
    result = cli(*args)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr + result.stdout
    assert len(result.stderr.strip().splitlines()) == 1


def test_malformed_bddl_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.bddl"
    bad.write_text(
        "(define (problem LIBERO_Tabletop_Manipulation)\n  (:domain robosuite)\n  (:goal (And (On a b))\n"
    )
    result = cli("show", str(bad))
    assert result.returncode == 2
    assert result.stderr.startswith(f"error: {bad}, line 3: unbalanced parentheses")
    assert "Traceback" not in result.stderr


def test_bad_flag_exits_2() -> None:
    result = cli("show", "libero_goal/0", "--size", "3")
    assert result.returncode == 2
    assert "Traceback" not in result.stderr


@pytest.mark.sim
def test_show_writes_both_cameras_side_by_side(tmp_path: Path) -> None:
    from PIL import Image

    out = tmp_path / "scene.png"
    result = cli("show", "libero_goal/0", "--out", str(out), "--size", "64")
    assert result.returncode == 0, result.stderr
    assert "(:goal" in result.stdout  # the BDDL is printed
    assert f"wrote {out}" in result.stdout
    picture = np.asarray(Image.open(out))
    assert picture.shape == (64, 128, 3)
    assert picture[:, :64].std() > 10 and picture[:, 64:].std() > 10


def test_card_states_the_expert_report_it_was_rendered_from(tmp_path: Path) -> None:
    header = {"settings": {"inits": 50, "seed": 0, "expert": "0123456789ab", "config": "", "versions": {}}}
    (tmp_path / "expert_report.jsonl").write_text(json.dumps(header) + "\n")
    (tmp_path / "expert_report.csv").write_text(
        "suite,index,name,episodes,successes,rate,mean_length,seconds_per_episode,failures\n"
        "libero_goal,5,push_the_plate_to_the_front_of_the_stove,50,24,0.480,814.4,10.1,x (26)\n"
    )
    out = tmp_path / "card.md"

    def card(report: Path) -> subprocess.CompletedProcess[str]:
        return cli("card", "--suite", "libero_goal", "--expert-report", str(report), "--out", str(out))

    result = card(tmp_path / "expert_report.csv")
    assert result.returncode == 0, result.stderr
    text = out.read_text()
    assert "| 48% (24/50) |" in text
    assert "| expert report: expert code | 0123456789ab |" in text
    assert (
        "as measured by the expert report (expert code 0123456789ab, init states per task 50, seed 0)."
        in text
    )
    # Without its journal the table still makes a card; it just cannot name the expert code.
    (tmp_path / "expert_report.jsonl").unlink()
    assert card(tmp_path / "expert_report.csv").returncode == 0
    assert "expert code" not in out.read_text()
    missing = card(tmp_path / "nope.csv")
    assert missing.returncode != 0 and "nope.csv does not exist" in missing.stderr + missing.stdout
    # With a committed report and its journal (the expert before issue 74, kept as it was):
    # success within the standard limit beside success at all, and the plot.
    import shutil

    before = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "expert_before_74"
    for name in ("expert_report.csv", "expert_report.jsonl"):
        shutil.copy(before / name, tmp_path / name)
    result = card(tmp_path / "expert_report.csv")
    assert result.returncode == 0 and f"wrote {out} and {tmp_path / 'card_lengths.png'}" in result.stdout
    assert "| 100% (50/50) | 0% (0/50) |" in out.read_text()  # libero_goal/3 then: solved, never within 300
    assert "![Episode lengths against the standard limit](card_lengths.png)" in out.read_text()
