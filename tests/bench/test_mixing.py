"""Training on a run's own data mixed with another dataset's episodes of its tasks' variants
(``libero-bench run --mix``): which episodes, the weight of each epoch, the held-out starts.

The second dataset is the tiny one copied with its tasks renamed as variants
(``<task>__language``, ``<task>__camera_l3``), a reworded instruction, and reset seeds set to
the first seed of each task's held-out stream: an evaluation that forgot the mixed episodes
would start where one of them did.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from bench_helpers import run_request, succeeds

from libero_bench.data.mixing import VARIANT_SEPARATOR, MixedWindows, MixEpisode, mixed_seeds
from libero_data.errors import InputError
from libero_data.seeding import heldout_seed, heldout_starts, loader_epoch_seed

pytestmark = pytest.mark.sim  # needs the generated tiny dataset

DRAWER = "open_the_middle_drawer_of_the_cabinet"
STOVE = "turn_on_the_stove"
REWORDED = "pull the middle drawer of the cabinet open"


@pytest.fixture(scope="module")
def variants(tiny_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("mix") / "variants"
    shutil.copytree(tiny_dataset, out)
    renamed = {DRAWER: f"{DRAWER}__language", STOVE: f"{STOVE}__camera_l3"}
    path = out / "meta" / "libero_episodes.jsonl"
    rows = [json.loads(line) for line in path.read_text().splitlines()]
    for row in rows:
        source = row["task_name"]
        row["task_name"] = renamed[source]
        row["reset_seed"] = heldout_seed(source, 0)
        if source == DRAWER:
            row["language"] = REWORDED
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    meta = json.loads((out / "meta" / "libero.json").read_text())
    for task in meta["tasks"]:
        task["language"] = REWORDED if task["name"] == DRAWER else task["language"]
        task["name"] = renamed[task["name"]]
    (out / "meta" / "libero.json").write_text(json.dumps(meta))
    return out


def _plan(tiny_dataset: Path, variants: Path, weight: float = 0.25, tasks: tuple[str, ...] = ("0", "7")):
    from libero_bench.train.plan import plan_run

    return plan_run(run_request(tiny_dataset, tasks=tasks, mix=(variants,), mix_weight=weight))


def test_each_task_takes_its_own_variants(tiny_dataset: Path, variants: Path) -> None:
    plan = _plan(tiny_dataset, variants)
    assert plan.mix is not None
    assert plan.mix.episodes == {
        0: [MixEpisode(0, 0, f"{DRAWER}__language", REWORDED)],
        1: [MixEpisode(0, 1, f"{STOVE}__camera_l3", "turn on the stove")],
    }
    # only the stove task: the drawer's variant is not its
    alone = _plan(tiny_dataset, variants, tasks=("7",))
    assert alone.mix is not None and list(alone.mix.episodes) == [0]
    # a reworded instruction gets an embedding of its own; a kept one shares the task's
    run_embs = plan.task_embs
    rows = {lang: plan.mix.embs[i] for i, lang in enumerate(plan.mix.languages)}
    np.testing.assert_array_equal(rows["turn on the stove"], run_embs[1])
    assert not np.array_equal(rows[REWORDED], run_embs[0]) and not np.array_equal(rows[REWORDED], run_embs[1])


def test_weights_are_honoured_and_the_epoch_keeps_its_length(tiny_dataset: Path, variants: Path) -> None:
    from libero_bench.train.fitting import task_loader

    for weight in (0.0, 0.25, 0.6):
        plan = _plan(tiny_dataset, variants, weight)
        loader = task_loader(plan, [0, 1], seed=3, device=torch.device("cpu"))
        data = loader.dataset
        assert isinstance(data, MixedWindows)
        own = len(data.base)
        assert data.mixed_len == own  # the copy has the same windows
        assert len(loader) == math.ceil(own / plan.preset.batch_size)  # same gradient steps
        for seed in (0, 1):
            order = data.epoch_indices(seed)
            mixed = sum(data.is_mixed(i) for i in order)
            assert len(order) == own and mixed == round(weight * own)
            assert len(set(order)) == len(order)  # without replacement here
            assert order == data.epoch_indices(seed)  # the seed decides
        # what the batches carry: the reworded instruction's embedding exactly on the mixed windows
        reworded = torch.from_numpy(plan.mix.embs[plan.mix.languages.index(REWORDED)])
        seen = sum(int((b["task_emb"] == reworded).all(dim=1).sum()) for b in loader)
        order = data.epoch_indices(loader_epoch_seed(loader.seed, loader.epoch))
        drawer_mixed = sum(1 for i in order if data.is_mixed(i) and data[i]["task_id"].item() == 0)
        assert seen == drawer_mixed
        assert (seen > 0) == (weight > 0)


def test_held_out_starts_skip_every_training_start(
    tiny_dataset: Path, variants: Path, tmp_path: Path
) -> None:
    from libero_bench.runs.folder import RunFolder
    from libero_bench.train.observer import RunObserver
    from libero_bench.train.plan import plan_run
    from libero_bench.train.rounds import EvaluationRounds

    plan = _plan(tiny_dataset, variants)
    base = plan_run(run_request(tiny_dataset, tasks=("0", "7")))
    n = plan.preset.eval_heldout
    assert n > 0
    for position, name in enumerate((DRAWER, STOVE)):
        seeds = plan.training_seeds(position)
        own = base.training_seeds(position)
        assert heldout_seed(name, 0) in seeds and own < seeds
        mixed = EvaluationRounds(plan, RunFolder(tmp_path / "a"), RunObserver()).eval_tasks()[position]
        unmixed = EvaluationRounds(base, RunFolder(tmp_path / "b"), RunObserver()).eval_tasks()[position]
        assert not set(mixed.heldout) & seeds
        assert unmixed.heldout[0] == heldout_seed(name, 0)  # what forgetting the mix would give
        assert list(mixed.heldout) == heldout_starts(name, n, avoid=seeds)


def test_a_mixed_run_records_its_mix(tiny_dataset: Path, variants: Path, tmp_path: Path) -> None:
    from libero_bench.train import rounds
    from libero_bench.train.trainer import RunOptions, Trainer
    from libero_data.runtime.files import read_json

    out = tmp_path / "run"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rounds, "run_round", succeeds)
        patch.setattr(Trainer, "collect_rollouts", lambda self, results: None)
        Trainer(_plan(tiny_dataset, variants, tasks=("7",)), out, RunOptions()).run()
    config = read_json(out / "config.json")
    assert config["mix"]["weight"] == 0.25
    assert (out / config["mix"]["datasets"][0]["data"]).resolve() == variants.resolve()  # named from the run
    assert config["mix"]["tasks"][STOVE] == {"variants": [f"{STOVE}__camera_l3"], "episodes": [[0, 1]]}
    assert mixed_seeds(config, out) == {STOVE: {heldout_seed(STOVE, 0)}}
    assert config["evaluation"]["training_starts"][STOVE]["demos_from_sampler"] == 2
    # resuming with another weight is refused, with the same one it is the same run
    from libero_data.errors import SettingsChanged

    with pytest.raises(SettingsChanged, match="'mix'"):
        Trainer(_plan(tiny_dataset, variants, 0.5, tasks=("7",)), out, RunOptions()).prepare()


def test_bad_mixes_are_refused(tiny_dataset: Path, variants: Path) -> None:
    for weight in (1.0, -0.1, float("nan")):
        with pytest.raises(InputError, match="mix weight"):
            _plan(tiny_dataset, variants, weight)
    shutil.copytree(variants, variants.parent / "other")
    other = variants.parent / "other"
    path = other / "meta" / "libero_episodes.jsonl"
    rows = [json.loads(line) for line in path.read_text().splitlines()]
    path.write_text("".join(json.dumps({**r, "task_name": "put_the_bowl__layout"}) + "\n" for r in rows))
    from libero_bench.train.plan import plan_run

    with pytest.raises(InputError, match="no episodes of turn_on_the_stove or of their variants"):
        plan_run(run_request(tiny_dataset, tasks=("7",), mix=(other,)))


def test_draws_with_the_same_variant_names_are_all_mixed(
    tiny_dataset: Path, variants: Path, tmp_path: Path
) -> None:
    """More draws of the same variants (``MORE=1`` in benchmarks/robustness_data.sh): datasets whose
    tasks have the same names each give their episodes, at the run's one weight, and the held-out
    starts avoid every draw's starts."""
    from libero_bench.runs.folder import RunFolder
    from libero_bench.train.fitting import task_loader
    from libero_bench.train.observer import RunObserver
    from libero_bench.train.plan import plan_run
    from libero_bench.train.rounds import EvaluationRounds

    second = variants.parent / "second-draw"
    shutil.copytree(variants, second)
    path = second / "meta" / "libero_episodes.jsonl"
    rows = [json.loads(line) for line in path.read_text().splitlines()]
    for row in rows:  # began where the second seed of its source task's held-out stream does
        row["reset_seed"] = heldout_seed(row["task_name"].split(VARIANT_SEPARATOR)[0], 1)
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))

    one = _plan(tiny_dataset, variants, 0.5)
    both = plan_run(run_request(tiny_dataset, tasks=("0", "7"), mix=(variants, second), mix_weight=0.5))
    assert one.mix is not None and both.mix is not None
    for position, name in enumerate((DRAWER, STOVE)):
        chosen = both.mix.episodes[position]
        assert {e.dataset for e in chosen} == {0, 1}
        assert len(chosen) == 2 * len(one.mix.episodes[position])
        assert {heldout_seed(name, 0), heldout_seed(name, 1)} <= both.training_seeds(position)
        heldout = EvaluationRounds(both, RunFolder(tmp_path), RunObserver()).eval_tasks()[position].heldout
        assert heldout[0] == heldout_seed(name, 2) and not set(heldout) & both.training_seeds(position)
    data = task_loader(both, [0, 1], seed=3, device=torch.device("cpu")).dataset
    single = task_loader(one, [0, 1], seed=3, device=torch.device("cpu")).dataset
    assert isinstance(data, MixedWindows) and isinstance(single, MixedWindows)
    assert data.mixed_len == 2 * single.mixed_len  # every draw's windows can be drawn
    assert data.epoch_len() == single.epoch_len() and data.mixed_count() == single.mixed_count()
    drawn = [i for i in data.epoch_indices(0) if data.is_mixed(i)]
    assert min(drawn) - len(data.base) < single.mixed_len <= max(drawn) - len(data.base)  # from both
