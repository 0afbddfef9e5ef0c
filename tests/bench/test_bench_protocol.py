"""The training protocol of every algorithm, with scripted evaluation outcomes instead of
simulation: the learning curve, the kept (best) checkpoint, the after-task evaluations,
PackNet's evaluation before fine-tuning, MTL, and resuming between task stages."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from typing import Any, ClassVar

import pytest
import torch

from libero_bench.algos import algo_class, algo_names
from libero_bench.rollouts.jobs import RolloutJob, RolloutResult
from libero_bench.runs.saved_policy import read_checkpoint
from libero_bench.train import rounds
from libero_bench.train.checkpoints import POST_TASK, load_epoch_state
from libero_bench.train.presets import SMOKE
from libero_bench.train.trainer import RunOptions, RunRequest, Trainer, plan_run

pytestmark = pytest.mark.sim  # needs the generated tiny dataset (no simulation runs here)

#: success rate of task k at epoch e while learning it (2 rollouts: 0, 0.5 or 1)
CURVE = {0: [0.0, 1.0, 0.5], 1: [0.5, 0.5, 1.0]}
#: the same from the one held-out start (its rollout 0 succeeds where the rate is >= 0.5)
HELDOUT_CURVE = [[0.0, 1.0, 1.0], [1.0, 1.0, 1.0]]
AFTER = 0.5
PRUNED = 1.0
PRESET = SMOKE.replace(epochs=2, batch_size=32, image_size=32, language_encoder="task_id")


def _digest(policy: torch.nn.Module) -> float:
    return float(
        sum(p.detach().double().sum() for p in policy.state_dict().values() if p.is_floating_point())
    )


class ScriptedEvaluator:
    """Stands in for a run's evaluation rounds (:func:`libero_bench.train.rounds.run_round`): successes
    come from the tables above; every call records the policy's weights digest."""

    calls: ClassVar[list[dict[str, Any]]] = []

    @classmethod
    def run(
        cls, environments: Any, policy: Any, jobs: list[RolloutJob], on_result: Any = None
    ) -> list[RolloutResult]:
        assert environments.executor.kind == "local"  # what RunOptions defaults to
        out = []
        for job in jobs:
            tags = job.tags
            if tags["phase"] == "learning":
                rate = CURVE[tags["task_position"]][tags["epoch"]]
            elif tags["phase"] == "after":
                rate = AFTER
            else:
                rate = PRUNED
            success = tags["rollout"] < round(rate * 2)
            out.append(RolloutResult(job.key, success, 3, 0.0))
            cls.calls.append({**tags, "digest": _digest(policy)})
        return out


@pytest.fixture
def scripted(monkeypatch: pytest.MonkeyPatch) -> type[ScriptedEvaluator]:
    ScriptedEvaluator.calls = []
    monkeypatch.setattr(rounds, "run_round", ScriptedEvaluator.run)
    monkeypatch.setattr(Trainer, "collect_rollouts", lambda self, results: None)
    return ScriptedEvaluator


def _trainer(data: Path, out: Path, algo: str, stop_after: int | None = None) -> Trainer:
    plan = plan_run(RunRequest(data=data, algo=algo, policy="resnet_t", preset=PRESET))
    return Trainer(plan, out, RunOptions(stop_after=stop_after))


@pytest.mark.parametrize("algo", algo_names())
def test_protocol(algo: str, tiny_dataset: Path, tmp_path: Path, scripted: type[ScriptedEvaluator]) -> None:
    results = _trainer(tiny_dataset, tmp_path / "run", algo).run()
    assert results.complete and results.stage == ["done", "done"]
    assert results.eval_epochs == [0, 1, 2]
    checkpoint = read_checkpoint(tmp_path / "run" / "checkpoints" / "task_000.safetensors")
    policy_digest = sum(v.double().sum() for v in checkpoint["policy"].values() if v.is_floating_point())
    if algo_class(algo).needs_all_tasks:
        # one multitask training, every task evaluated at every epoch, best mean kept (epoch 1)
        assert results.curve == [CURVE[0], CURVE[1]]
        assert results.best_epoch == [1, 1]
        assert results.after == [[1.0, 0.5], [1.0, 0.5]]
        assert results.curve_heldout == HELDOUT_CURVE
        assert results.after_heldout == [[1.0, 1.0], [1.0, 1.0]]  # the kept epoch's, not the best
        assert not (tmp_path / "run" / "checkpoints" / "task_001.safetensors").exists()
        kept = [c["digest"] for c in scripted.calls if c["epoch"] == 1]
        assert float(policy_digest) == pytest.approx(kept[0], rel=1e-12)
        return
    assert results.curve == [CURVE[0], CURVE[1]]
    assert results.best_epoch == [1, 2]  # the earliest best epoch
    assert results.after[0][0] == 1.0 and results.after[1][1] == 1.0
    assert results.after[1][0] == AFTER and math.isnan(results.after[0][1])
    # From held-out starts: the curve as measured, and the kept checkpoint's value on the diagonal.
    assert results.curve_heldout == HELDOUT_CURVE
    assert results.after_heldout[0][0] == 1.0 and results.after_heldout[1] == [1.0, 1.0]
    phases = [
        (c["phase"], c["learned_after_position"], c["task_position"], c["start"]) for c in scripted.calls
    ]
    after_calls = [p for p in phases if p[0] == "after"]
    # 2 rollouts of task 0 from stored starts after task 1, and 1 from a held-out start
    assert after_calls == [("after", 1, 0, "stored"), ("after", 1, 0, "stored"), ("after", 1, 0, "heldout")]
    assert [len(loss) for loss in results.losses] == [3, 3]
    kept = next(c["digest"] for c in scripted.calls if c["epoch"] == 1 and c["task_position"] == 0)
    if algo == "packnet":
        # evaluated once more after pruning, before fine-tuning; the curve is untouched by it
        assert results.pruned == [PRUNED, PRUNED]
        assert [len(loss) for loss in results.post_losses] == [1, 1]
        assert phases.index(("pruned", 0, 0, "stored")) < phases.index(("learning", 1, 1, "stored"))
        assert float(policy_digest) != pytest.approx(kept, rel=1e-9)  # pruned and fine-tuned
    else:
        assert results.pruned == [None, None]
        # the checkpoint holds the weights evaluated at the best epoch
        assert float(policy_digest) == pytest.approx(kept, rel=1e-12)


def test_resume_after_the_checkpoint_redoes_only_the_after_task_evaluations(
    tiny_dataset: Path, tmp_path: Path, scripted: type[ScriptedEvaluator]
) -> None:
    out = tmp_path / "run"
    first = _trainer(tiny_dataset, out, "er").run()
    saved = json.loads((out / "results.json").read_text())
    # as if killed after task 1's checkpoint, before the earlier task was evaluated again
    interrupted = dict(saved, complete=False, stage=["done", "trained"])
    interrupted["after"] = [[1.0, None], [None, 1.0]]
    interrupted["after_heldout"] = [[1.0, None], [None, 1.0]]
    interrupted["rollouts"] = [r for r in saved["rollouts"] if r["phase"] != "after"]
    (out / "results.json").write_text(json.dumps(interrupted))
    scripted.calls = []
    again = _trainer(tiny_dataset, out, "er").run()
    assert [c["phase"] for c in scripted.calls] == ["after", "after", "after"]
    assert again.to_dict() == first.to_dict()
    # the digest of the weights used for the after-task evaluation is the saved checkpoint's
    checkpoint = read_checkpoint(out / "checkpoints" / "task_001.safetensors")
    digest = float(sum(v.double().sum() for v in checkpoint["policy"].values() if v.is_floating_point()))
    assert scripted.calls[0]["digest"] == pytest.approx(digest, rel=1e-12)


def test_a_run_folder_refuses_other_settings(tiny_dataset: Path, tmp_path: Path, scripted: Any) -> None:
    out = tmp_path / "run"
    _trainer(tiny_dataset, out, "seql").run()
    with pytest.raises(ValueError, match="holds a run with a different 'algo'"):
        _trainer(tiny_dataset, out, "ewc").prepare()


def test_a_run_starts_from_another_runs_weights(tiny_dataset: Path, tmp_path: Path, scripted: Any) -> None:
    # The paper's pretraining study: MTL first, then a lifelong run from its weights.
    _trainer(tiny_dataset, tmp_path / "mtl", "mtl").run()
    weights = tmp_path / "mtl" / "checkpoints" / "task_000.safetensors"
    start = read_checkpoint(weights)["policy"]
    digest = float(sum(v.double().sum() for v in start.values() if v.is_floating_point()))
    scripted.calls = []
    request = RunRequest(
        data=tiny_dataset, algo="seql", policy="resnet_t", preset=PRESET, init_checkpoint=weights
    )
    Trainer(plan_run(request), tmp_path / "seql", RunOptions()).run()
    first = scripted.calls[0]  # epoch 0 of the first task: before any training
    assert (first["phase"], first["epoch"]) == ("learning", 0)
    assert first["digest"] == pytest.approx(digest, rel=1e-12)
    other = RunRequest(data=tiny_dataset, algo="seql", policy="vit_t", preset=PRESET, init_checkpoint=weights)
    with pytest.raises(ValueError, match="does not fit the vit_t policy"):
        Trainer(plan_run(other), tmp_path / "vit", RunOptions()).run()


def test_a_run_stopped_after_its_first_tasks_goes_on_in_a_copy_of_its_folder_with_the_same_numbers(
    tiny_dataset: Path, tmp_path: Path, scripted: type[ScriptedEvaluator]
) -> None:
    # benchmarks/lifelong.sh sweeps PackNet and EWC on the first tasks with --stop-after, then continues
    # the kept setting's folder (copied) instead of learning those tasks again.
    import shutil

    whole = _trainer(tiny_dataset, tmp_path / "whole", "packnet").run()
    stopped = _trainer(tiny_dataset, tmp_path / "sweep", "packnet", stop_after=1).run()
    assert stopped.stage[0] == "done" and stopped.stage[1] != "done" and not stopped.complete
    assert not (tmp_path / "sweep" / "checkpoints" / "task_001.safetensors").exists()
    shutil.copytree(tmp_path / "sweep", tmp_path / "kept")
    continued = _trainer(tiny_dataset, tmp_path / "kept", "packnet").run()
    assert continued.complete and continued.to_dict() == whole.to_dict()
    for name in ("task_000", "task_001"):
        a = read_checkpoint(tmp_path / "whole" / "checkpoints" / f"{name}.safetensors")["policy"]
        b = read_checkpoint(tmp_path / "kept" / "checkpoints" / f"{name}.safetensors")["policy"]
        assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    with pytest.raises(ValueError, match="--stop-after applies to algorithms that learn task by task"):
        _trainer(tiny_dataset, tmp_path / "mtl", "mtl", stop_after=1)


def test_packnet_interrupted_twice_in_its_second_task_goes_on_with_the_same_numbers_and_weights(
    tiny_dataset: Path, tmp_path: Path, scripted: type[ScriptedEvaluator], monkeypatch: pytest.MonkeyPatch
) -> None:
    # In its second task PackNet keeps the first task's weights fixed; a resumed epoch must too.
    # The post-task fine-tuning (after pruning) is saved epoch by epoch like the task's epochs.
    request = RunRequest(
        data=tiny_dataset,
        algo="packnet",
        policy="resnet_t",
        preset=PRESET,
        algo_settings=("post_prune_epochs=2",),
    )
    whole = Trainer(plan_run(request), tmp_path / "whole", RunOptions()).run()
    timings = (tmp_path / "whole" / "timings.jsonl").read_text()
    assert timings.count('"what": "epoch"') == 2 * (3 + 2) and timings.count("post-task epoch") == 4
    second = plan_run(request).tasks[1].name
    fit_epoch = Trainer._fit_epoch
    state = tmp_path / "resumed" / "checkpoints" / "task_001.epoch.safetensors"
    for stop_in in (
        "epoch 2/2",
        "post-task epoch 2/2",
    ):  # killed in the task's epochs, then in the fine-tuning

        def interrupted(
            self: Trainer, algo: Any, policy: Any, loader: Any, optimiser: Any, label: str
        ) -> Any:
            if label == f"{second}: {stop_in}":  # noqa: B023 (called before the loop goes on)
                raise KeyboardInterrupt
            return fit_epoch(self, algo, policy, loader, optimiser, label)

        monkeypatch.setattr(Trainer, "_fit_epoch", interrupted)
        with pytest.raises(KeyboardInterrupt):
            Trainer(plan_run(request), tmp_path / "resumed", RunOptions()).run()
        post = load_epoch_state(state, [1], phase=POST_TASK)
        assert (post is not None) == stop_in.startswith("post-task")
    monkeypatch.setattr(Trainer, "_fit_epoch", fit_epoch)
    scripted.calls = []
    resumed = Trainer(plan_run(request), tmp_path / "resumed", RunOptions()).run()
    assert resumed.to_dict() == whole.to_dict() and [len(x) for x in resumed.post_losses] == [2, 2]
    assert not state.exists()
    # Resumed in the fine-tuning: the task's pruned network is not evaluated again.
    assert not any(c["phase"] == "pruned" for c in scripted.calls)
    for name in ("task_000", "task_001"):
        a = read_checkpoint(tmp_path / "whole" / "checkpoints" / f"{name}.safetensors")["policy"]
        b = read_checkpoint(tmp_path / "resumed" / "checkpoints" / f"{name}.safetensors")["policy"]
        assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_the_ewc_probe_reads_a_runs_two_checkpoints(
    tiny_dataset: Path, tmp_path: Path, scripted: type[ScriptedEvaluator]
) -> None:
    # benchmarks/lifelong_ewc_probe.py: where EWC's forgetting lives, from the checkpoints after tasks 0 and 1
    from benchmarks.lifelong_ewc_probe import markdown, probe

    _trainer(tiny_dataset, tmp_path / "ewc", "ewc").run()
    row = probe(tmp_path / "ewc")
    after0 = read_checkpoint(tmp_path / "ewc" / "checkpoints" / "task_000.safetensors")
    after1 = read_checkpoint(tmp_path / "ewc" / "checkpoints" / "task_001.safetensors")["policy"]
    anchor = after0["algo"]["anchor"]
    assert row["penalty_weight"] == 5e4 and row["weights"] == sum(t.numel() for t in anchor.values())
    assert all(
        torch.equal(anchor[n], after0["policy"][n]) for n in anchor
    )  # the anchor: the weights after task 0
    total = math.sqrt(sum(float((after1[n] - anchor[n]).pow(2).sum()) for n in anchor))
    halves = math.hypot(row["moved_high_fisher_half"], row["moved_low_fisher_half"])
    assert total > 0 and halves == pytest.approx(total, rel=1e-5)
    assert 0.0 <= row["share_stiffness_above_1"] <= 1.0
    losses = row["task0_loss"]
    assert len(set(losses.values())) == 4 and all(math.isfinite(v) for v in losses.values())
    assert "| ewc | 50000 |" in markdown([row])


def test_er_carried_without_its_memory_rebuilds_it_and_goes_on_bit_for_bit(
    er_run: Path, tiny_dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A run carried to another machine (benchmarks/lifelong_carry.py) leaves ER's windows behind
    # (120 MB at 64x64): the memory updates ER records rebuild them from the data, and the run
    # goes on with the same numbers and weights as er_run, made in one go.
    from benchmarks.lifelong_carry import carry_in, carry_out
    from libero_bench.runs.saved_policy import EPOCH_STATE
    from libero_bench.runs.state_files import load_state
    from tests.bench.bench_helpers import run_request, succeeds

    monkeypatch.setattr(rounds, "run_round", succeeds)
    monkeypatch.setattr(Trainer, "collect_rollouts", lambda self, results: None)
    second = plan_run(run_request(tiny_dataset)).tasks[1].name
    fit_epoch = Trainer._fit_epoch

    def interrupted(self: Trainer, algo: Any, policy: Any, loader: Any, optimiser: Any, label: str) -> Any:
        if label == f"{second}: epoch 1/1":  # after the loss pass, before the epoch that replays
            raise KeyboardInterrupt
        return fit_epoch(self, algo, policy, loader, optimiser, label)

    run = tmp_path / "work" / "runs" / "er"
    monkeypatch.setattr(Trainer, "_fit_epoch", interrupted)
    with pytest.raises(KeyboardInterrupt):
        Trainer(plan_run(run_request(tiny_dataset)), run, RunOptions()).run()
    monkeypatch.setattr(Trainer, "_fit_epoch", fit_epoch)
    manifest = carry_out(tmp_path / "work", tmp_path / "carry")
    files = manifest["runs"]["er"]["files"]
    assert {
        "checkpoints/task_000.safetensors",
        "checkpoints/task_001.epoch.safetensors",
        "results.json",
    } <= set(files)
    carried = load_state(
        tmp_path / "carry" / "er" / "checkpoints" / "task_001.epoch.safetensors", kind=EPOCH_STATE
    )
    assert "memories" not in carried["algo"] and len(carried["algo"]["fills"]) == 1
    shutil.rmtree(run)  # the next machine has the repository and the data made again, nothing else
    assert carry_in(tmp_path / "carry", tmp_path / "work") == ["er"]
    recorded = sorted(r["key"] for r in json.loads((run / "results.json").read_text())["rollouts"])
    assert recorded and json.loads((run / ".work" / "left_behind.json").read_text()) == recorded
    resumed = Trainer(plan_run(run_request(tiny_dataset)), run, RunOptions()).run()
    assert resumed.to_dict() == json.loads((er_run / "results.json").read_text())
    a = read_checkpoint(er_run / "checkpoints" / "task_001.safetensors")
    b = read_checkpoint(run / "checkpoints" / "task_001.safetensors")
    assert a["policy"].keys() == b["policy"].keys()
    assert all(torch.equal(a["policy"][k], b["policy"][k]) for k in a["policy"])
    memories_a, memories_b = a["algo"]["memories"], b["algo"]["memories"]
    assert memories_a.keys() == memories_b.keys() == {0, 1}
    for task in memories_a:
        assert all(torch.equal(memories_a[task][k], memories_b[task][k]) for k in memories_a[task])


def test_a_carried_run_refuses_other_data(tiny_dataset: Path, tmp_path: Path) -> None:
    from benchmarks.lifelong_carry import carry_in, carry_out

    work = tmp_path / "work"
    shutil.copytree(tiny_dataset, work / "data")
    run = work / "runs" / "seql"
    run.mkdir(parents=True)  # a run in progress, as far as carrying goes
    (run / "config.json").write_text(json.dumps({"data": "../../data"}))
    (run / "results.json").write_text(json.dumps({"complete": False, "rollouts": []}))
    carry_out(work, tmp_path / "carry")
    shutil.rmtree(run)
    table = sorted((work / "data" / "data").rglob("*.parquet"))[0]
    table.write_bytes(table.read_bytes() + b"\0")  # the data made again, but not the same
    with pytest.raises(SystemExit, match="is not the dataset seql learned from"):
        carry_in(tmp_path / "carry", work)
    assert not list((work / "runs").iterdir())  # nothing half put back


def test_a_finished_run_is_carried_only_when_named(tiny_dataset: Path, tmp_path: Path) -> None:
    # benchmarks/pace.sh names its finished runs: their final checkpoint and results travel, to be
    # evaluated and reported on (not their dataset: neither reads it).
    from benchmarks.lifelong_carry import carry_in, carry_out
    from libero_bench.runs.saved_policy import CHECKPOINT
    from libero_bench.runs.state_files import save_state

    work = tmp_path / "work"
    shutil.copytree(tiny_dataset, work / "data")
    run = work / "runs" / "done"
    (run / "checkpoints").mkdir(parents=True)
    (run / "config.json").write_text(json.dumps({"data": "../../data"}))
    (run / "results.json").write_text(json.dumps({"complete": True, "rollouts": []}))
    for task in range(2):
        save_state(run / "checkpoints" / f"task_00{task}.safetensors", {"task": task}, kind=CHECKPOINT)
    final = (run / "checkpoints" / "task_001.safetensors").read_bytes()
    assert carry_out(work, tmp_path / "carry")["runs"] == {}
    manifest = carry_out(work, tmp_path / "carry", also=["done"])
    assert set(manifest["runs"]["done"]["files"]) == {
        "config.json",
        "results.json",
        "checkpoints/task_001.safetensors",
    }
    assert manifest["data"] == {} and manifest["runs"]["done"]["datasets"] == {}  # evaluation needs none
    shutil.rmtree(work)
    assert carry_in(tmp_path / "carry", work) == ["done"]
    assert (work / "runs" / "done" / "checkpoints" / "task_001.safetensors").read_bytes() == final


def test_a_carried_run_brings_its_dataset_to_a_machine_that_has_none(
    tiny_dataset: Path, tmp_path: Path
) -> None:
    # A dataset made again on another machine may have other bytes (its videos), so the carry holds
    # the dataset too, and carry-in puts it where the run looks for it, checked file by file.
    from benchmarks.lifelong_carry import carry_in, carry_out, data_digest, dataset_files

    work = tmp_path / "work"
    shutil.copytree(tiny_dataset, work / "data")
    (work / "data" / "mcap").mkdir(exist_ok=True)
    (work / "data" / "mcap" / "episode_000000.mcap").write_bytes(b"log")  # not needed to train
    card = work / "data" / "README.md"
    card.write_text(card.read_text() + f"\n- **Made by:** `libero-data generate ... --out {work / 'data'}`\n")
    run = work / "runs" / "seql"
    run.mkdir(parents=True)
    (run / "config.json").write_text(json.dumps({"data": "../../data"}))
    (run / "results.json").write_text(json.dumps({"complete": False, "rollouts": []}))
    digest = data_digest(work / "data")
    manifest = carry_out(work, tmp_path / "carry")
    files = manifest["dataset_files"]["data"]
    assert files and not any(name.startswith("mcap/") for name in files)
    carried_card = (tmp_path / "carry" / "datasets" / "data" / "README.md").read_text()
    assert str(tmp_path) not in carried_card and "--out data`" in carried_card  # no path of this machine
    assert carried_card == card.read_text().replace(str(work / "data"), "data")
    assert {"data", "videos", "meta"} <= {name.split("/")[0] for name in files}

    tampered = tmp_path / "carry" / "datasets" / "data" / sorted(files)[-1]
    original = tampered.read_bytes()
    shutil.rmtree(work)  # the next machine: the repository only
    tampered.write_bytes(original + b"\0")
    with pytest.raises(SystemExit, match=r"differs from what carry\.json records"):
        carry_in(tmp_path / "carry", work)
    assert [p.name for p in work.iterdir()] == ["runs"] and not list(
        (work / "runs").iterdir()
    )  # nothing half put back

    tampered.write_bytes(original)
    assert carry_in(tmp_path / "carry", work) == ["seql"]
    assert data_digest(work / "data") == digest
    assert sorted(p.as_posix() for p in dataset_files(work / "data")) == sorted(files)
    assert (work / "data" / "README.md").read_text() == carried_card  # its folder named by itself
    for name in set(files) - {"README.md"}:  # the rest as made
        assert (work / "data" / name).read_bytes() == (tiny_dataset / name).read_bytes()

    # the same dataset made again elsewhere is compared with the carried one file by file
    import pyarrow as pa
    import pyarrow.parquet as pq

    from benchmarks.lifelong_carry import _video_difference, diff

    lines = diff(tmp_path / "carry", work / "data")
    assert lines and all(line.endswith(": the same") for line in lines)
    table_path = sorted((work / "data" / "data").rglob("*.parquet"))[0]
    table = pq.read_table(table_path)
    moved = pa.array(
        [[v + 1e-3 for v in row] for row in table.column("action").to_pylist()], pa.list_(pa.float32())
    )
    pq.write_table(table.set_column(table.column_names.index("action"), "action", moved), table_path)
    line = next(
        x
        for x in diff(tmp_path / "carry", work / "data")
        if x.startswith(str(table_path.relative_to(work / "data")))
    )
    assert "action (max 0.001)" in line and "observation.state" not in line
    video = sorted((work / "data" / "videos").rglob("*.mp4"))[0]
    assert _video_difference(video, video).startswith("0/")


def test_the_rollout_join_goes_without_the_rollouts_a_carried_run_left_behind(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from libero_bench.rollouts import rollout_dataset
    from libero_bench.rollouts.session import RolloutSession
    from libero_data.errors import RunError

    built: dict[str, Any] = {}

    def build(shards: list[Path], out: Path, *, run_meta: dict[str, Any], **_: Any) -> int:
        built.update(shards=[p.name for p in shards], meta=run_meta)
        return len(shards)

    monkeypatch.setattr(rollout_dataset, "build_rollout_dataset", build)
    session = RolloutSession(tmp_path)
    session.records = {k: {"key": k} for k in ("a", "b", "c")}
    (session.folder.shard("c")).mkdir(parents=True)
    (session.folder.shard("c") / "episode.json").write_text("{}")  # made on this machine
    with pytest.raises(RunError, match="rollout a is missing"):
        session.join({"run": "r"}, {})
    session.folder.left_behind.write_text(json.dumps(["a", "b"]))  # carried from another machine
    assert session.join({"run": "r"}, {}) == 1
    assert built == {"shards": ["c"], "meta": {"run": "r", "rollouts_left_behind": ["a", "b"]}}


def test_a_carried_evaluation_names_no_path_of_the_machine(tmp_path: Path) -> None:
    # benchmarks/pace.sh commits standard evaluations: their paths must resolve on another machine.
    from benchmarks.lifelong_carry import portable_copy

    work = tmp_path / "work"
    (work / "standard" / "a").mkdir(parents=True)
    bddl = "/opt/venv/lib/python3.12/site-packages/libero/libero/bddl_files/libero_goal/t.bddl"
    config = {"run": str(work / "runs" / "a"), "data": f"{work}/runs/a/../../a-64", "bddl": bddl}
    (work / "standard" / "a" / "config.json").write_text(json.dumps(config))
    (work / "standard" / "a" / "report.md").write_text(f"Policy: `{work / 'runs' / 'a'}`.\n")
    for name in ("config.json", "report.md"):
        portable_copy(work / "standard" / "a" / name, tmp_path / name, work)
    assert json.loads((tmp_path / "config.json").read_text()) == {
        "run": "../../runs/a",
        "data": "../../a-64",
        "bddl": "libero/libero/bddl_files/libero_goal/t.bddl",
    }
    assert (tmp_path / "report.md").read_text() == "Policy: `../../runs/a`.\n"


def test_a_carried_evaluation_finds_its_run_in_the_carry_and_again_once_carried_back(
    tmp_path: Path,
) -> None:
    # A carry keeps a run at CARRY/<run>, not at WORK/runs/<run>: the evaluation's paths follow it.
    from benchmarks.lifelong_carry import portable_copy

    work, carry, back = tmp_path / "work", tmp_path / "carry", tmp_path / "back"
    for folder in (work / "standard" / "a", carry / "standard" / "a", back / "standard" / "a"):
        folder.mkdir(parents=True)
    (carry / "a").mkdir()
    (back / "runs" / "a").mkdir(parents=True)
    report = {"policy": str(work / "runs" / "a"), "data": str(work / "a-64")}
    (work / "standard" / "a" / "report.json").write_text(json.dumps(report))
    carried = carry / "standard" / "a" / "report.json"
    portable_copy(work / "standard" / "a" / "report.json", carried, work, [(work / "runs", carry)])
    assert json.loads(carried.read_text()) == {"policy": "../../a", "data": "../../a-64"}
    assert (carried.parent / "../../a").is_dir()
    returned = back / "standard" / "a" / "report.json"
    portable_copy(carried, returned, back, [(carry / "a", back / "runs" / "a")])
    assert json.loads(returned.read_text()) == {"policy": "../../runs/a", "data": "../../a-64"}
    assert (returned.parent / "../../runs/a").is_dir()


def test_the_pace_report_tables_the_runs_evaluated_and_pairs_them_start_for_start(tmp_path: Path) -> None:
    from benchmarks import pace_report

    def evaluated(name: str, successes: list[bool]) -> None:
        (tmp_path / "standard" / name).mkdir(parents=True)
        rollouts = [{"init_index": i, "success": s} for i, s in enumerate(successes)]
        (tmp_path / "standard" / name / "results.json").write_text(json.dumps({"rollouts": rollouts}))
        (tmp_path / "standard" / name / "report.json").write_text("{}")  # the evaluation is complete
        (tmp_path / "runs" / name).mkdir(parents=True)
        own = [{"epoch": 16, "start": "stored", "success": s} for s in successes]
        (tmp_path / "runs" / name / "results.json").write_text(json.dumps({"rollouts": own}))

    evaluated("before-spatial-7", [False, False, True, False])
    evaluated("after-spatial-7", [True, False, True, True])
    evaluated("tail-spatial-7", [True, True])
    (tmp_path / "standard" / "tail-spatial-7" / "report.json").unlink()  # still being made: left out
    opens = {str(k): {"open": k + 3, "of": 25} for k in (-3, -1, 0, 1, 2)} | {"5": {"open": 0, "of": 0}}
    (tmp_path / "standard" / "after-spatial-7" / "release.json").write_text(json.dumps({"opens": opens}))
    assert pace_report.main([str(tmp_path), "--out", str(tmp_path / "out")]) == 0
    report = (tmp_path / "out" / "pace.md").read_text()
    assert "| `after-spatial-7` | 0/25 | 2/25 | 3/25 | 4/25 | 5/25 | – |" in report
    assert "| libero_goal/3 | today | `after-goal-3` | 300 | not evaluated yet | | | |" in report
    assert (
        "| libero_10/0 | today, 10 steps after the goal | `tail-long-0` | 520 | not evaluated yet |" in report
    )
    assert "| libero_spatial/7 | `before-spatial-7` | `after-spatial-7` | 1/4 | 3/4 | 0 | 2 | 0.5 |" in report
    pairs = json.loads((tmp_path / "out" / "pace.json").read_text())["pairs"]
    assert pairs == {"before-spatial-7 vs after-spatial-7": {"n": 4, "only_a": 0, "only_b": 2, "p": 0.5}}
    assert (
        "| libero_spatial/7 | today, 10 steps after the goal | `tail-spatial-7` | 220 | not evaluated yet |"
        in report
    )


def test_the_pace_report_tells_failures_that_stop_from_those_still_moving(tmp_path: Path) -> None:
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    from benchmarks.pace_report import how_failures_end

    rollouts = tmp_path / "rollouts"
    (rollouts / "data" / "chunk-000").mkdir(parents=True)
    (rollouts / "meta").mkdir()
    steps = 80
    still = np.zeros((steps, 7))  # stays put, gripper closed
    moving = np.zeros((steps, 7))
    moving[:, 0] = np.linspace(0.0, 0.4, steps)  # 40 cm along x, gripper open
    poses = np.concatenate([still, moving])
    actions = np.zeros((2 * steps, 7))
    actions[:steps, 6], actions[steps:, 6] = 1.0, -1.0
    table = {
        "action": [list(a) for a in actions],
        "libero.eef_pose": [list(p) for p in poses],
        "episode_index": [0] * steps + [1] * steps,
    }
    pq.write_table(pa.table(table), rollouts / "data" / "chunk-000" / "file-000.parquet")
    rows = [{"episode_index": 0, "success": False}, {"episode_index": 1, "success": False}]
    (rollouts / "meta" / "libero_episodes.jsonl").write_text("\n".join(json.dumps(r) for r in rows))
    assert how_failures_end(tmp_path) == {"failures": 2, "stopped": 1, "stopped_closed": 1}
    shutil.rmtree(rollouts)  # carried without its rollouts: what was written beside it is read
    assert how_failures_end(tmp_path) == {"failures": 2, "stopped": 1, "stopped_closed": 1}
    assert how_failures_end(tmp_path / "elsewhere") is None
