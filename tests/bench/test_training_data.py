"""A run records what evaluating it needs from its training data (training_data.json) and names
its datasets relative to itself, so a run folder copied without them (a committed run) is still
evaluated from held-out starts that avoid its demonstrations'; older runs resume and migrate."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from libero_bench.runs.training_data import TRAINING_DATA, from_datasets, read_training_data
from libero_data.errors import MissingFileError


def _demo_seeds(dataset: Path) -> dict[str, set[int]]:
    seeds: dict[str, set[int]] = {}
    for line in (dataset / "meta" / "libero_episodes.jsonl").read_text().splitlines():
        row = json.loads(line)
        seeds.setdefault(row["task_name"], set()).add(int(row["reset_seed"]))
    return seeds


def test_a_run_records_its_training_starts_and_names_its_data_relative_to_itself(
    er_run: Path, tiny_dataset: Path
) -> None:
    config = json.loads((er_run / "config.json").read_text())
    assert not Path(config["data"]).is_absolute()
    assert (er_run / config["data"]).resolve() == tiny_dataset.resolve()
    recorded = read_training_data(er_run)
    assert recorded is not None
    assert recorded == from_datasets(er_run, config)
    assert {name: set(seeds) for name, (_, seeds) in recorded.starts.items()} == _demo_seeds(tiny_dataset)
    assert recorded.sim_state_width > 0


def test_a_run_copied_without_its_data_is_evaluated_from_its_record(
    er_run: Path, tiny_dataset: Path, tmp_path: Path
) -> None:
    from libero_bench.rollouts.policy_kinds import policy_source
    from libero_data.seeding import heldout_starts

    copy = tmp_path / "elsewhere" / "run"
    shutil.copytree(er_run, copy)
    config = json.loads((copy / "config.json").read_text())
    assert not (copy / config["data"]).exists()  # its dataset did not come along
    dataset, starts = policy_source(str(copy)).training_starts()
    assert dataset == str(copy / config["data"])  # where the run says its data was
    seeds = _demo_seeds(tiny_dataset)
    assert {name: found[1] for name, found in starts.items()} == seeds
    for name, avoid in seeds.items():  # held-out starts skip every seed a demonstration began from
        assert not set(heldout_starts(name, 20, avoid=avoid)) & avoid

    # Without the record (a run from before it), the missing dataset is one sentence with the way out.
    (copy / TRAINING_DATA).unlink()
    with pytest.raises(MissingFileError, match=r"which does not exist, and the run does not record") as e:
        policy_source(str(copy)).training_starts()
    assert "libero-bench migrate" in str(e.value) and "--heldout 0" in str(e.value)


def test_an_earlier_run_naming_its_data_absolutely_resumes_and_migrates(
    er_run: Path, tiny_dataset: Path, tmp_path: Path
) -> None:
    from bench_helpers import run_request

    from libero_bench.runs.migrate import migrate
    from libero_bench.train.trainer import RunOptions, Trainer, plan_run

    run = tmp_path / "earlier"
    shutil.copytree(er_run, run)
    recorded = (run / TRAINING_DATA).read_text()
    (run / TRAINING_DATA).unlink()
    config = json.loads((run / "config.json").read_text())
    config["data"] = str(tiny_dataset.resolve())  # as runs named it before
    (run / "config.json").write_text(json.dumps(config))
    # Migrating records where its demonstrations started, from its dataset, as a new run does.
    (done,) = migrate(run)
    assert done.kind == "training data" and (run / TRAINING_DATA).read_text() == recorded
    with pytest.raises(MissingFileError, match="nothing to migrate"):
        migrate(run)
    # It resumes: the absolute path names the same dataset as the relative one a run writes now.
    Trainer(plan_run(run_request(tiny_dataset)), run, RunOptions()).prepare()


def test_a_damaged_record_is_one_sentence(er_run: Path, tmp_path: Path) -> None:
    from libero_data.errors import FileFormatError

    run = tmp_path / "run"
    shutil.copytree(er_run, run)
    (run / TRAINING_DATA).write_text('{"format": "libero-bench-training-data/1", "tasks": 3}')
    with pytest.raises(FileFormatError, match=r"training_data.json is not a run's training-data record"):
        read_training_data(run)
