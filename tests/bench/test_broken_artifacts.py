"""A corpus of broken artifacts, each given to the commands that open it: datasets, run folders,
evaluation folders, policy folders, checkpoints, BDDL files and suite folders, each missing,
truncated, edited or of a foreign format. Every one is refused in one sentence that names the
file, with exit code 2, no traceback, and nothing written."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from lerobot_policies import save_policy
from typer.testing import CliRunner

import libero_bench.cli
import libero_data.cli

pytestmark = pytest.mark.sim  # the tiny dataset (no simulation runs here)


@dataclass(frozen=True)
class Case:
    """A broken copy of an artifact (``breaks`` edits it) and the command that opens it."""

    artifact: str  # "dataset", "run", "policy", "eval", "suite" or "bddl"
    breaks: Callable[[Path], Path]  # edits the copy; returns the file the sentence must name
    command: Callable[[Path, Path], list[Any]]  # (broken artifact, scratch folder) -> arguments
    says: str  # a phrase of the sentence
    tool: str = "bench"


def _write(relative: str, text: str) -> Callable[[Path], Path]:
    def edit(root: Path) -> Path:
        (root / relative).write_text(text)
        return root / relative

    return edit


def _write_bytes(relative: str, data: bytes) -> Callable[[Path], Path]:
    def edit(root: Path) -> Path:
        (root / relative).write_bytes(data)
        return root / relative

    return edit


def _remove(relative: str) -> Callable[[Path], Path]:
    def edit(root: Path) -> Path:
        path = root / relative
        shutil.rmtree(path) if path.is_dir() else path.unlink()
        return path

    return edit


def _truncate(relative: str, keep: int = 100) -> Callable[[Path], Path]:
    def edit(root: Path) -> Path:
        path = root / relative
        if path.is_dir():  # the first file of a folder (a parquet chunk)
            path = sorted(p for p in path.rglob("*") if p.is_file() and not p.name.startswith("."))[0]
        path.write_bytes(path.read_bytes()[:keep])
        return path

    return edit


def _edit_json(relative: str, change: Callable[[Any], Any]) -> Callable[[Path], Path]:
    def edit(root: Path) -> Path:
        path = root / relative
        path.write_text(json.dumps(change(json.loads(path.read_text()))))
        return path

    return edit


def _without(key: str) -> Callable[[Any], Any]:
    return lambda data: {k: v for k, v in data.items() if k != key}


def _train(dataset: Path, scratch: Path) -> list[Any]:
    return ["run", "--data", dataset, "--set", "language_encoder=task_id", "--out", scratch / "new"]


def _sweep(run: Path, scratch: Path) -> list[Any]:
    return ["robustness", run, "--tasks", "libero_goal/0", "--kinds", "noise", "--out", scratch / "new"]


def _eval(policy: Path, scratch: Path) -> list[Any]:
    return ["eval", policy, "--tasks", "libero_goal/0", "--out", scratch / "new"]


def _other_weights(root: Path) -> Path:
    from safetensors.torch import save_file

    from libero_bench.runs.saved_policy import read_checkpoint

    path = root / "checkpoints" / "task_001.safetensors"
    weights = read_checkpoint(path)["policy"]
    save_file({k: v.contiguous() for k, v in weights.items()}, str(path))  # bare weights, no algorithm
    return path


def _wrong_shapes(root: Path) -> Path:
    from libero_bench.runs.saved_policy import CHECKPOINT, read_checkpoint
    from libero_bench.runs.state_files import save_state

    path = root / "checkpoints" / "task_001.safetensors"
    state = read_checkpoint(path)
    name = sorted(state["policy"])[0]
    state["policy"][name] = state["policy"][name].flatten()[:3].clone()
    save_state(path, state, kind=CHECKPOINT)
    return path


#: The settings the shared run was made with (bench_helpers.run_request), to resume it.
RESUME = ["run", "--algo", "er", "--policy", "resnet_t", "--preset", "smoke"] + [
    arg
    for field in ("epochs=1", "batch_size=32", "image_size=32", "language_encoder=task_id")
    for arg in ("--set", field)
]

CASES: dict[str, Case] = {
    # datasets, opened by `libero-bench run` and `libero-data validate`
    "dataset: info.json not JSON": Case(
        "dataset", _write("meta/info.json", "{not json"), _train, "not valid JSON"
    ),
    "dataset: libero.json not JSON": Case(
        "dataset", _write("meta/libero.json", '{"tasks": ['), _train, "not valid JSON"
    ),
    "dataset: an episode's record not JSON": Case(
        "dataset",
        _write("meta/libero_episodes.jsonl", '{"episode_index": 0'),
        _train,
        "line 1 is not valid JSON",
    ),
    "dataset: another LeRobot version": Case(
        "dataset",
        _edit_json("meta/info.json", lambda d: {**d, "codebase_version": "v2.1"}),
        _train,
        "v2.1",
    ),
    "dataset: parquet truncated": Case("dataset", _truncate("data"), _train, "parquet"),
    "dataset: episodes table missing": Case("dataset", _remove("meta/episodes"), _train, "episodes"),
    "dataset: a camera's videos missing": Case(
        "dataset", _remove("videos/observation.images.image"), _train, "holds no videos"
    ),
    "dataset: info.json not JSON (replay)": Case(
        "dataset",
        _write("meta/info.json", "{"),
        lambda d, s: ["replay", d, "--rrd", s / "new"],
        "not valid JSON",
        tool="data",
    ),
    "dataset: parquet truncated (replay)": Case(
        "dataset", _truncate("data"), lambda d, s: ["replay", d, "--rrd", s / "new"], "parquet", tool="data"
    ),
    "dataset: libero.json not JSON (rerender)": Case(
        "dataset",
        _write("meta/libero.json", "{"),
        lambda d, s: ["rerender", d, "--image-size", "32", "--out", s / "new"],
        "not valid JSON",
        tool="data",
    ),
    "dataset: parquet truncated (rerender)": Case(
        "dataset",
        _truncate("data"),
        lambda d, s: ["rerender", d, "--image-size", "32", "--out", s / "new"],
        "parquet",
        tool="data",
    ),
    "dataset: a folder that is not a dataset": Case("dataset", _remove("meta"), _train, "no meta/info.json"),
    # run folders, opened by robustness, serve, saliency, report, replay and run (resume)
    "run: config.json not JSON": Case("run", _write("config.json", "{"), _sweep, "not valid JSON"),
    "run: config.json without tasks": Case(
        "run", _edit_json("config.json", _without("tasks")), _sweep, "tasks"
    ),
    "run: config.json edited policy config": Case(
        "run",
        _edit_json("config.json", lambda d: {**d, "policy_config": {"name": "resnet_t", "size": "huge"}}),
        _sweep,
        "config.json",
    ),
    "run: results.json not JSON (report)": Case(
        "run", _write("results.json", "nul"), lambda r, s: ["report", r, "--out", s / "new"], "not valid JSON"
    ),
    "run: results.json edited (report)": Case(
        "run",
        _edit_json("results.json", _without("stage")),
        lambda r, s: ["report", r, "--out", s / "new"],
        "results.json",
    ),
    "run: results.json not JSON (resume)": Case(
        "run",
        _write("results.json", "]"),
        lambda r, s: [*RESUME, "--data", r / json.loads((r / "config.json").read_text())["data"], "--out", r],
        "not valid JSON",
    ),
    "run: checkpoint missing": Case("run", _remove("checkpoints/task_001.safetensors"), _sweep, "is missing"),
    "run: checkpoint missing (serve)": Case(
        "run",
        _remove("checkpoints/task_001.safetensors"),
        lambda r, s: ["serve", r, "--port", "1"],
        "checkpoint",
    ),
    "run: checkpoint truncated": Case(
        "run", _truncate("checkpoints/task_001.safetensors", 300), _sweep, "not a safetensors file"
    ),
    "run: checkpoint of bare weights": Case("run", _other_weights, _sweep, "holds bare weights"),
    "run: checkpoint of another architecture": Case("run", _wrong_shapes, _sweep, "does not fit"),
    "run: checkpoint truncated (saliency)": Case(
        "run",
        _truncate("checkpoints/task_001.safetensors", 300),
        lambda r, s: ["saliency", r, "--task", "1", "--out", s / "new"],
        "not a safetensors file",
    ),
    "run: no config.json (report)": Case(
        "run",
        _remove("config.json"),
        lambda r, s: ["report", r, "--out", s / "new"],
        "not a libero-bench run",
    ),
    "run: a foreign config (report)": Case(
        "run",
        _edit_json("config.json", lambda d: {**d, "format": "someone-elses/3"}),
        lambda r, s: ["report", r, "--out", s / "new"],
        "config.json",
    ),
    # LeRobot policy folders, opened by eval, robustness and serve
    "policy: config.json without type": Case(
        "policy", _write("config.json", '{"n_obs_steps": 1}'), _eval, "type"
    ),
    "policy: config.json not JSON": Case("policy", _write("config.json", "{"), _eval, "config.json"),
    "policy: weights missing": Case("policy", _remove("model.safetensors"), _eval, "weights"),
    "policy: weights truncated": Case(
        "policy", _truncate("model.safetensors", 50), _eval, "not a safetensors"
    ),
    "policy: weights truncated (serve)": Case(
        "policy",
        _truncate("model.safetensors", 50),
        lambda p, s: ["serve", p, "--port", "1"],
        "not a safetensors",
    ),
    "run: checkpoint missing (eval)": Case(
        "run", _remove("checkpoints/task_001.safetensors"), _eval, "is missing"
    ),
    # evaluation folders being resumed
    "eval: config.json not JSON": Case(
        "eval", _write("config.json", "{"), lambda e, s: [*_eval(s / "policy", s)[:-1], e], "not valid JSON"
    ),
    # suite folders and BDDL files, opened by libero-data and as evaluation tasks
    "suite: suite.json not JSON": Case(
        "suite",
        _write("suite.json", "{"),
        lambda f, s: ["tasks", "--suite", f],
        "not valid JSON",
        tool="data",
    ),
    "suite: suite.json without tasks": Case(
        "suite", _write("suite.json", "{}"), lambda f, s: ["tasks", "--suite", f], "tasks", tool="data"
    ),
    "suite: a task's BDDL missing": Case(
        "suite", _remove("tasks/0000.bddl"), lambda f, s: ["tasks", "--suite", f], "0000.bddl", tool="data"
    ),
    "expert table: no successes column (card)": Case(
        "bddl",
        _write("expert_report.csv", "name,episodes\nopen_the_middle_drawer_of_the_cabinet,10\n"),
        lambda f, s: [
            "card",
            "--suite",
            "libero_goal",
            "--expert-report",
            f / "expert_report.csv",
            "--out",
            s / "new.png",
        ],
        "no 'successes' column",
        tool="data",
    ),
    "bddl: unbalanced": Case(
        "bddl",
        _write("task.bddl", "(define (problem x)"),
        lambda b, s: ["show", b / "task.bddl", "--out", s / "new.png"],
        "line",
        tool="data",
    ),
    "bddl: not text": Case(
        "bddl",
        _write_bytes("task.bddl", b"\x89PNG\r\n\x1a\n\xff\xfe"),
        lambda b, s: ["show", b / "task.bddl", "--out", s / "new.png"],
        "task.bddl",
        tool="data",
    ),
}


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns) for p in root.rglob("*")}


@pytest.fixture(scope="module")
def originals(tiny_dataset: Path, er_run: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    from libero_data.tasks import get_task

    root = tmp_path_factory.mktemp("originals")
    suite = root / "suite"
    (suite / "tasks").mkdir(parents=True)
    shutil.copy(get_task("libero_goal/0").bddl_path, suite / "tasks" / "0000.bddl")
    (suite / "suite.json").write_text(
        json.dumps({"name": "mine", "tasks": [{"name": "a", "bddl": "tasks/0000.bddl"}]})
    )
    policy = save_policy("act", root / "policy")
    evaluation = root / "eval"
    evaluation.mkdir()
    (evaluation / "config.json").write_text(json.dumps({"format": "libero-bench-eval/1"}))
    bddl = root / "bddl"
    bddl.mkdir()
    return {
        "dataset": tiny_dataset,
        "run": er_run,
        "policy": policy,
        "eval": evaluation,
        "suite": suite,
        "bddl": bddl,
    }


@pytest.mark.parametrize("name", list(CASES))
def test_a_broken_artifact_is_one_sentence_naming_it(
    name: str, originals: dict[str, Path], tmp_path: Path
) -> None:
    case = CASES[name]
    broken = tmp_path / case.artifact
    ignore = shutil.ignore_patterns(".libero-data", "rollouts", "rrd", "variants")
    shutil.copytree(originals[case.artifact], broken, ignore=ignore)
    if case.artifact == "eval":
        shutil.copytree(originals["policy"], tmp_path / "policy")
    named = case.breaks(broken)
    before = _tree(broken)
    app = libero_bench.cli.app if case.tool == "bench" else libero_data.cli.app
    result = CliRunner().invoke(app, [str(a) for a in case.command(broken, tmp_path)])
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == 2 and "Traceback" not in result.output, (
        result.exit_code,
        result.output[-3000:],
    )
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert named.name in lines[0] and case.says in lines[0], lines[0]
    assert result.stdout == ""  # a refusal is its sentence alone
    assert not (tmp_path / "new").exists() and not (tmp_path / "new.png").exists()  # nothing written
    assert _tree(broken) == before  # the artifact is left as it was
