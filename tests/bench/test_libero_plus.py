"""``libero-bench eval --benchmark libero-plus``: the tasks it draws, the prompt it sends, its table."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.openpi_loop import RecordingServer
from libero_data.tasks.plus import CATEGORIES, ENV_VAR, PREFIX, file_name_prompt
from libero_data.tasks.plus_cache import plus_infos
from libero_data.tasks.plus_sample import plus_plan


@pytest.fixture
def plus(plus_wheel: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv(ENV_VAR, str(plus_wheel))
    monkeypatch.delenv("LIBERO_DATA_PLUS_ASSETS", raising=False)
    return plus_wheel


def test_the_sample_is_stratified_and_the_same_for_the_same_seed(plus: Path) -> None:
    infos = plus_infos(PREFIX + "libero_object")
    plan = plus_plan(["libero_object"], per_category=3, seed=5)["libero_object"]
    assert plan == plus_plan(["libero_object"], per_category=3, seed=5)["libero_object"]
    assert plan != plus_plan(["libero_object"], per_category=3, seed=6)["libero_object"]
    counts = {c: sum(infos[i].category == c for i in plan["run"]) for c in CATEGORIES}
    assert counts == {
        "camera": 3,
        "robot": 3,
        "language": 3,
        "light": 0,
        "background": 3,
        "noise": 3,
        "layout": 3,
    }
    assert plan["not_run"] == {"light": 297, "background": 186, "layout": 208}  # their assets, added objects
    # by difficulty: with levels given, each level in turn
    cameras = [i for i in infos if i.category == "camera"]
    levels = {i.parsed.name: 1 + k % 3 for k, i in enumerate(cameras)}
    drawn = plus_plan(["libero_object"], per_category=3, seed=5, difficulty=levels)["libero_object"]["run"]
    assert sorted(levels[infos[i].parsed.name] for i in drawn if infos[i].category == "camera") == [1, 2, 3]
    # a LIBERO task: the LIBERO-Plus tasks made from it
    base = plus_plan(["libero_object/0"])["libero_object"]
    source = infos[base["run"][0]].parsed.base
    assert all(infos[i].parsed.base == source for i in base["run"]) and len(base["run"]) > 100


def test_the_raw_prompt_is_their_file_name(plus: Path) -> None:
    from libero_data.tasks import get_suite

    tasks = get_suite(PREFIX + "libero_spatial").tasks
    infos = plus_infos(PREFIX + "libero_spatial")
    robot = next(i for i in infos if i.category == "robot")
    assert file_name_prompt(tasks[robot.index]).endswith(f"initstate {robot.parsed.robot}")
    language = next(i for i in infos if i.category == "language")
    assert file_name_prompt(tasks[language.index]) == tasks[language.index].language


@pytest.mark.sim
@pytest.mark.slow  # six scenes built through the command line (~50 s)
def test_eval_benchmark_libero_plus_per_category_writes_its_table(plus: Path, tmp_path: Path) -> None:
    server = RecordingServer()
    with server.running():
        command = [sys.executable, "-m", "libero_bench.cli", "eval", "--server", server.url]
        command += ["--benchmark", "libero-plus", "--plus", str(plus), "--tasks", "libero_object/0"]
        command += [
            "--per-category",
            "1",
            "--max-steps",
            "5",
            "--workers",
            "2",
            "--out",
            str(tmp_path / "plus"),
        ]
        done = subprocess.run(command, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    table = json.loads((tmp_path / "plus" / "libero_plus.json").read_text())
    (row,) = table["rows"]
    assert row["suite"] == "libero_object" and table["categories"] == list(CATEGORIES)
    runs = {c: row["cells"][c]["n"] for c in CATEGORIES}
    assert runs == {
        "camera": 1,
        "robot": 1,
        "language": 1,
        "light": 0,
        "background": 1,
        "noise": 1,
        "layout": 1,
    }
    assert row["total"]["n"] == 6 and row["not_run"]["light"] > 0
    assert not table["standard"]  # 5 steps instead of the suite's 280
    text = (tmp_path / "plus" / "libero_plus.md").read_text()
    assert "| suite | Camera | Robot | Language | Light | Background | Noise | Layout | Total |" in text
    assert (tmp_path / "plus" / "libero_plus.png").is_file()
    prompts = {r["prompt"] for requests in server.requests.values() for r in requests}
    assert prompts and not any("initstate" in p or " view " in p for p in prompts)


def test_difficulty_comes_from_their_classification(plus: Path, tmp_path: Path) -> None:
    from libero_data.tasks.plus_sample import read_difficulty

    assert read_difficulty() == {}  # the wheel carries none
    path = tmp_path / "task_classification.json"
    entries = [{"id": 1, "name": "a", "category": "Sensor Noise", "difficulty_level": 3}]
    path.write_text(
        json.dumps({"libero_object": [*entries, {"id": 2, "name": "b", "difficulty_level": None}]})
    )
    assert read_difficulty(path) == {"a": 3}
