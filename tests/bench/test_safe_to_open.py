"""Nothing libero-bench opens runs code: checkpoints are safetensors with a JSON header, pickles
are refused by every command in one sentence, and `libero-bench migrate` converts an earlier
version's run folder (with torch's restricted loader, which refuses code as well)."""

from __future__ import annotations

import os
import pickle
import random
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
from bench_helpers import run_request, succeeds
from typer.testing import CliRunner

from libero_bench.cli import app
from libero_bench.runs.migrate import migrate
from libero_bench.runs.saved_policy import CHECKPOINT, EPOCH_STATE, read_checkpoint
from libero_bench.runs.state_files import is_pickle, load_state, load_weights, save_state
from libero_bench.train import rounds
from libero_bench.train.trainer import RunOptions, Trainer, plan_run
from libero_data.errors import CheckpointError


class _Evil:
    """Unpickling this runs ``touch MARKER``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, ...]:
        return (os.system, (f"touch {self.marker}",))


def _evil_pickle(path: Path, marker: Path, *, torch_save: bool = False) -> Path:
    """A checkpoint-like pickle whose loading runs code: written by torch.save, or by pickle."""
    content = {"policy": _Evil(marker), "algo": {}}
    if torch_save:
        torch.save(content, path)
    else:
        path.write_bytes(pickle.dumps(content))
    return path


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, torch.Tensor):
        return isinstance(b, torch.Tensor) and a.dtype == b.dtype and torch.equal(a, b)
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and np.array_equal(a, b)
    if isinstance(a, dict):
        return isinstance(b, dict) and list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and a != a:
        return isinstance(b, float) and b != b
    return type(a) is type(b) and a == b


def test_a_state_comes_back_as_it_was(tmp_path: Path) -> None:
    model = torch.nn.Linear(3, 2)
    optimiser = torch.optim.AdamW(model.parameters(), lr=1e-3)
    model(torch.ones(1, 3)).sum().backward()
    optimiser.step()  # optimiser state: int keys, tuples of betas, step tensors
    state = {
        "policy": model.state_dict(),
        "optimiser": optimiser.state_dict(),
        "memories": {0: {"x": torch.arange(6, dtype=torch.uint8)}, 3: {}},
        "rng": {
            "torch": torch.get_rng_state(),
            "numpy": np.random.get_state(),
            "python": random.getstate(),
            "pcg": np.random.default_rng(7).bit_generator.state,  # 128-bit integers
        },
        "best_rate": -float("inf"),
        "nan": float("nan"),
        "half": torch.ones(2, dtype=torch.bfloat16),
        "empty": np.zeros((0, 3), dtype=np.float32),
        "nothing": None,
        "losses": [{"epoch": 0, "total": np.float64(0.5)}],
    }
    path = save_state(tmp_path / "state.safetensors", state, kind=EPOCH_STATE)
    back = load_state(path, kind=EPOCH_STATE)
    state["losses"] = [{"epoch": 0, "total": 0.5}]  # NumPy scalars come back as Python numbers
    assert _same(state, back)
    # what it holds is checked before anything is used
    with pytest.raises(
        CheckpointError, match="holds a libero-bench epoch state, not a libero-bench checkpoint"
    ):
        load_state(path, kind=CHECKPOINT)
    with pytest.raises(TypeError, match="cannot be stored"):
        save_state(tmp_path / "bad.safetensors", {"x": object()}, kind=CHECKPOINT)


def test_the_same_state_is_the_same_bytes_in_any_process(tmp_path: Path) -> None:
    """safetensors writes its header from a hash map whose order changes from one process to
    the next; the header is rewritten in sorted order, so a checkpoint's bytes depend on the
    state alone (and safetensors still reads it)."""
    import subprocess
    import sys

    code = (
        "import sys, torch\n"
        "from libero_bench.runs.state_files import save_state\n"
        "state = {'b': torch.arange(5.0), 'a': {'z': torch.ones(3, dtype=torch.uint8), 'y': 'text'}}\n"
        "save_state(__import__('pathlib').Path(sys.argv[1]), state, kind='libero-bench checkpoint')\n"
    )
    paths = [tmp_path / f"{i}.safetensors" for i in range(4)]
    for path in paths:
        subprocess.run([sys.executable, "-c", code, str(path)], check=True)
    assert len({p.read_bytes() for p in paths}) == 1
    back = load_state(paths[0], kind=CHECKPOINT)
    assert torch.equal(back["b"], torch.arange(5.0)) and back["a"]["y"] == "text"
    import json

    raw = paths[0].read_bytes()
    keys: list[list[str]] = []
    json.loads(
        raw[8 : 8 + int.from_bytes(raw[:8], "little")],
        object_pairs_hook=lambda pairs: keys.append([k for k, _ in pairs]),
    )
    top = keys[-1]  # the header itself, parsed last; the metadata's keys, parsed before it
    meta = next(k for k in keys if "libero_bench_kind" in k)
    assert top[0] == "__metadata__" and top[1:] == sorted(top[1:]) and meta == sorted(meta)


def test_bare_weights_and_damaged_files(tmp_path: Path) -> None:
    from safetensors.torch import save_file

    bare = tmp_path / "model.safetensors"
    save_file({"weight": torch.ones(2, 2)}, str(bare))
    assert torch.equal(load_weights(bare)["weight"], torch.ones(2, 2))
    truncated = tmp_path / "truncated.safetensors"
    truncated.write_bytes(bare.read_bytes()[:40])
    with pytest.raises(CheckpointError, match=r"truncated.safetensors is not a safetensors file"):
        load_weights(truncated)
    with pytest.raises(CheckpointError, match="holds bare weights, not a libero-bench checkpoint"):
        read_checkpoint(bare)
    legacy = tmp_path / "task_000.pt"
    torch.save({"weight": torch.ones(1)}, legacy)
    assert is_pickle(legacy)
    with pytest.raises(CheckpointError, match=r"is a pickled torch checkpoint; .*libero-bench migrate"):
        load_weights(legacy)


def _cli(*args: str | Path) -> Any:
    return CliRunner().invoke(app, [str(a) for a in args])


def _one_sentence(result: Any) -> str:
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == 2, (result.exit_code, result.output)
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in result.output, (
        result.stderr
    )
    return str(lines[0])


def test_a_pickle_that_runs_code_is_never_opened(er_run: Path, tiny_dataset: Path, tmp_path: Path) -> None:
    marker = tmp_path / "ran-code"
    # The payload is real: unpickling it would call os.system (read from the pickle's opcodes by
    # torch, without running it; nothing in this test unpickles it).
    probe = _evil_pickle(tmp_path / "probe.pt", marker, torch_save=True)
    assert torch.serialization.get_unsafe_globals_in_checkpoint(probe) == [f"{os.system.__module__}.system"]
    evil = _evil_pickle(tmp_path / "evil.pt", marker, torch_save=True)
    disguised = _evil_pickle(tmp_path / "weights.safetensors", marker)
    run = tmp_path / "shared-run"
    shutil.copytree(er_run, run)
    (run / "checkpoints" / "task_001.safetensors").unlink()
    _evil_pickle(run / "checkpoints" / "task_001.pt", marker)
    train = ("run", "--data", tiny_dataset, "--preset", "smoke", "--set", "language_encoder=task_id")
    commands = {
        "run --init-checkpoint": (*train, "--init-checkpoint", evil, "--out", tmp_path / "new"),
        "run --init-checkpoint (renamed)": (
            *train,
            "--init-checkpoint",
            disguised,
            "--out",
            tmp_path / "new",
        ),
        "run (resume)": (*train, "--out", run),
        "robustness": ("robustness", run, "--tasks", "libero_goal/0", "--out", tmp_path / "sweep"),
        "saliency": ("saliency", run, "--task", "0", "--out", tmp_path / "saliency"),
        "serve": ("serve", run, "--port", "1"),
        "eval": ("eval", run, "--tasks", "libero_goal/0", "--out", tmp_path / "eval"),
        "report": ("report", run, "--out", tmp_path / "report"),
        "compare": ("compare", run, er_run, "--out", tmp_path / "compare"),
        "replay": ("replay", run, "--task", "0", "--rrd", tmp_path / "replay.rrd"),
        "migrate (folder)": ("migrate", run),
        "migrate (file)": ("migrate", evil, "--out", tmp_path / "converted.safetensors"),
    }
    sentences = {}
    for name, args in commands.items():
        sentences[name] = _one_sentence(_cli(*args))
        assert not marker.exists(), f"{name} ran the pickle's code"
    for name in (
        "run --init-checkpoint",
        "run (resume)",
        "robustness",
        "saliency",
        "serve",
        "report",
        "replay",
    ):
        assert "pickled" in sentences[name] and "libero-bench migrate" in sentences[name], sentences[name]
    assert "cannot be read as a checkpoint of tensors" in sentences["migrate (file)"]
    assert "it would call posix.system" in sentences["migrate (file)"], sentences["migrate (file)"]
    # nothing was written
    for made in (
        "new",
        "sweep",
        "saliency",
        "eval",
        "report",
        "compare",
        "replay.rrd",
        "converted.safetensors",
    ):
        assert not (tmp_path / made).exists(), made
    assert (run / "checkpoints" / "task_001.pt").is_file()  # a refused migrate leaves the folder as it was


def test_an_earlier_runs_pickles_are_migrated(er_run: Path, tiny_dataset: Path, tmp_path: Path) -> None:
    run = tmp_path / "earlier"
    shutil.copytree(er_run, run)
    originals = {}
    for path in sorted((run / "checkpoints").glob("*.safetensors")):
        originals[path.name] = read_checkpoint(path)
        torch.save(originals[path.name], path.with_suffix(".pt"))  # what the earlier writer made
        path.unlink()
    assert set(originals) == {"task_000.safetensors", "task_001.safetensors"}
    trainer = Trainer(plan_run(run_request(tiny_dataset)), run, RunOptions())
    with pytest.raises(CheckpointError, match=r"holds pickled checkpoints \(task_000.pt, task_001.pt\)"):
        trainer.prepare()
    converted = migrate(run)
    assert [c.target.name for c in converted] == sorted(originals)
    assert not list((run / "checkpoints").glob("*.pt"))
    for name, original in originals.items():
        assert _same(original, read_checkpoint(run / "checkpoints" / name))
    assert original["algo"]["memories"].keys() == {0, 1}  # ER's memories, keyed by task number
    # the migrated run reads as before: finished, nothing redone
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rounds, "run_round", succeeds)
        patch.setattr(Trainer, "collect_rollouts", lambda self, results: None)
        again = Trainer(plan_run(run_request(tiny_dataset)), run, RunOptions()).run()
    assert again.complete


def test_initial_weights_must_fit_the_policy(er_run: Path, tiny_dataset: Path, tmp_path: Path) -> None:
    from safetensors.torch import save_file

    weights = read_checkpoint(er_run / "checkpoints" / "task_000.safetensors")["policy"]
    bare = tmp_path / "bare.safetensors"
    save_file({k: v.contiguous() for k, v in weights.items()}, str(bare))
    plan_run(run_request(tiny_dataset, init_checkpoint=bare))  # bare weights of this policy: accepted
    wrong = tmp_path / "wrong.safetensors"
    save_file({"layer.weight": torch.ones(2)}, str(wrong))
    with pytest.raises(ValueError, match=r"wrong.safetensors does not fit the resnet_t policy"):
        plan_run(run_request(tiny_dataset, init_checkpoint=wrong))


def test_a_safetensors_header_of_128_bytes_is_not_taken_for_a_pickle(tmp_path: Path) -> None:
    """A safetensors file starts with its header's length: 128 bytes begins with 0x80, the byte
    a pickle starts with; the header's ``{`` after it tells them apart."""
    header = b'{"__metadata__":{"k":"v"}}'.ljust(128)
    safetensors_like = tmp_path / "a.safetensors"
    safetensors_like.write_bytes((128).to_bytes(8, "little") + header)
    pickled = tmp_path / "b.pt"
    pickled.write_bytes(b"\x80\x02}q\x00.")
    assert not is_pickle(safetensors_like) and is_pickle(pickled)
