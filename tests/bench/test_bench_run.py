"""End to end through the CLI: a 2-task ER run in simulation, its rollout dataset, MCAP logs,
Rerun recordings, report, replay, saliency, and resuming after SIGKILL."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from libero_bench.runs import metrics

# One xdist worker runs this module (its run is built once) and the other Ray test: two local
# Ray instances at once would crowd 2 cores and memory.
pytestmark = [pytest.mark.sim, pytest.mark.xdist_group("ray")]

#: The smoke preset, shortened: 2 tasks x (epochs 0, 1, 2) x (2 stored + 1 held-out) rollouts,
#: and 2 + 1 after-task rollouts. Two epochs so that a run can be killed in the middle of a task.
RUN_ARGS = [
    "--algo",
    "er",
    "--policy",
    "resnet_t",
    "--preset",
    "smoke",
    "--set",
    "eval_every=2",
    "--set",
    "eval_max_steps=6",
    "--set",
    "language_encoder=task_id",
]


def bench(*args: str, timeout: float = 600) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "SVT_LOG": "1"}
    return subprocess.run(
        [sys.executable, "-m", "libero_bench.cli", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
    )


@pytest.fixture(scope="module")
def bench_run(tiny_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bench") / "run"
    started = time.monotonic()
    result = bench("run", "--data", str(tiny_dataset), *RUN_ARGS, "--workers", "2", "--out", str(out))
    assert result.returncode == 0, result.stderr[-3000:]
    assert "er + resnet_t" in result.stdout  # the closing table
    print(f"bench run: {time.monotonic() - started:.0f} s")
    return out


def kill_once(command: list[str], ready: Callable[[], bool], what: str) -> None:
    """Start ``command`` and SIGKILL it as soon as ``ready()`` holds (within 10 minutes)."""
    env = {**os.environ, "OMP_NUM_THREADS": "1", "SVT_LOG": "1"}
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    deadline = time.monotonic() + 600
    try:
        while not ready():
            assert proc.poll() is None, f"the run ended before {what}"
            assert time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()


def _results(run: Path) -> dict:
    return json.loads((run / "results.json").read_text())


def _episodes(run: Path) -> list[dict]:
    text = (run / "rollouts" / "meta" / "libero_episodes.jsonl").read_text()
    return [json.loads(line) for line in text.splitlines()]


def test_run_folder_and_results(bench_run: Path) -> None:
    from libero_data.numerics import machine_fingerprint

    config = json.loads((bench_run / "config.json").read_text())
    assert config["preset"]["epochs"] == 2 and config["preset"]["eval_max_steps"] == 6
    # The run names the numeric path it ran on (pinned, as this test process is).
    machines = config["runtime"]["machines"]
    assert config["runtime"]["threads"] == 1  # torch threads: last-bit differences follow them
    assert [m["numeric_key"] for m in machines] == [machine_fingerprint()["numeric_key"]]
    assert {b["kernel"] for b in machines[0]["blas"]} and machines[0]["libm"]
    assert [t["name"] for t in config["tasks"]] == [
        "open_the_middle_drawer_of_the_cabinet",
        "turn_on_the_stove",
    ]
    results = _results(bench_run)
    assert results["complete"] and results["stage"] == ["done", "done"]
    assert results["eval_epochs"] == [0, 2]
    curve = np.array(results["curve"], dtype=float)
    after = np.array(results["after"], dtype=float)
    assert curve.shape == (2, 2) and np.isfinite(curve).all()
    assert np.isfinite(after[1, 0]) and math.isnan(after[0, 1])
    assert after[0, 0] == curve[0].max() and after[1, 1] == curve[1].max()
    assert len(results["losses"][0]) == 3 and all(math.isfinite(e["total"]) for e in results["losses"][0])
    assert len(results["rollouts"]) == 2 * 2 * 3 + 3
    # Held-out starts: placements of the task's own stream, none a demonstration started from.
    heldout = [r for r in results["rollouts"] if r["start"] == "heldout"]
    assert len(heldout) == 5 and all(r["init_index"] == -1 for r in heldout)
    from libero_data.seeding import heldout_starts

    rows = (
        (bench_run / config["data"] / "meta" / "libero_episodes.jsonl").read_text().splitlines()
    )  # named from the run
    demo_seeds = {json.loads(line)["reset_seed"] for line in rows}
    for r in heldout:
        assert r["env_seed"] == heldout_starts(r["task"], 1, avoid=demo_seeds)[0]
        assert r["env_seed"] not in demo_seeds
    curve_heldout = np.array(results["curve_heldout"], dtype=float)
    assert curve_heldout.shape == (2, 2) and np.isfinite(curve_heldout).all()
    assert config["evaluation"]["heldout_arm_noise"] == 0.02  # as LIBERO's stored init states
    starts = config["evaluation"]["training_starts"]
    assert all(s["recorded"] and s["stored_eval_starts_trained_on"] == [] for s in starts.values())
    for k in range(2):
        assert (bench_run / "checkpoints" / f"task_{k:03d}.safetensors").is_file()


def test_rollout_dataset_loads_and_matches_the_success_matrix(bench_run: Path) -> None:
    import datasets

    episodes = _episodes(bench_run)
    frames = datasets.load_dataset(str(bench_run / "rollouts"), split="train")
    assert len(frames) == sum(e["length"] for e in episodes)
    assert sorted(set(frames["episode_index"])) == list(range(len(episodes)))
    assert "action" in frames.column_names and "observation.state" in frames.column_names

    results = _results(bench_run)
    rates: dict[tuple, list[bool]] = defaultdict(list)
    for e in episodes:
        assert {"task_name", "learned_after", "epoch", "run_seed", "init_index", "success"} <= set(e)
        assert e["run_seed"] == 0
        assert e["init_index"] == (e["rollout"] if e["start"] == "stored" else -1)
        key = (e["phase"], e["learned_after_position"], e["task_position"], e["epoch"], e["start"])
        rates[key].append(e["success"])
    epochs = results["eval_epochs"]
    for k in range(2):
        for i, epoch in enumerate(epochs):
            assert np.mean(rates[("learning", k, k, epoch, "stored")]) == results["curve"][k][i]
            assert np.mean(rates[("learning", k, k, epoch, "heldout")]) == results["curve_heldout"][k][i]
    assert np.mean(rates[("after", 1, 0, None, "stored")]) == results["after"][1][0]
    # the rollout list in results.json and the dataset tell the same story, episode by episode
    by_key = {r["key"]: r for r in results["rollouts"]}
    assert sorted(by_key) == [e["key"] for e in episodes]
    for e in episodes:
        assert by_key[e["key"]]["success"] == e["success"] and by_key[e["key"]]["steps"] == e["length"]


def test_every_rollout_has_an_mcap_log_and_a_rerun_recording(bench_run: Path) -> None:
    import rerun.recording as rd

    from libero_data.record.mcap_log import read_mcap

    episodes = _episodes(bench_run)
    mcaps = sorted((bench_run / "rollouts" / "mcap").glob("*.mcap"))
    assert len(mcaps) == len(episodes)
    topics = {topic for topic, _, _ in read_mcap(mcaps[0])}
    assert any("image" in t or "camera" in t for t in topics), topics
    rrds = sorted((bench_run / "rrd").glob("*.rrd"))
    assert [p.stem for p in rrds] == [e["key"] for e in episodes]

    episode = episodes[-1]
    recording = rd.load_recording(str(bench_run / "rrd" / f"{episode['key']}.rrd"))
    table = recording.view(index="step", contents="/**").select().read_all()
    columns = set(table.column_names)
    for needed in (
        "/cameras/agentview:EncodedImage:blob",
        "/cameras/eye_in_hand:EncodedImage:blob",
        "/action/gripper:Scalars:scalars",
        "/state/eef_z:Scalars:scalars",
        "/success:Scalars:scalars",
    ):
        assert needed in columns, sorted(columns)
    steps = table.column("step").to_pylist()
    assert steps == list(range(episode["length"]))
    language = recording.view(index="step", contents="/language").select_static().read_all()
    assert episode["language"] in str(language.to_pylist())
    success = [v[0] for v in table.column("/success:Scalars:scalars").to_pylist()]
    assert bool(success[-1]) == episode["success"]


def test_report(bench_run: Path, tmp_path: Path) -> None:
    result = bench("report", str(bench_run), str(bench_run), "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert "FWT" in result.stdout and "er + resnet_t" in result.stdout
    report = json.loads((tmp_path / "report.json").read_text())
    results = _results(bench_run)
    curve = np.array(results["curve"], dtype=float)
    after = np.array(results["after"], dtype=float)
    (group,) = report["groups"]
    stored = group["stored"]
    assert stored["fwt"]["mean"] == pytest.approx(metrics.fwt(curve))
    assert stored["nbt"]["mean"] == pytest.approx(metrics.nbt(curve, after))
    assert stored["auc"]["mean"] == pytest.approx(metrics.auc(curve, after))
    for name in ("fwt", "auc"):  # every number with its interval (the same run twice)
        assert stored[name]["low"] <= stored[name]["mean"] <= stored[name]["high"]
    assert [f["n"] for f in stored["final"]] == [4, 4]  # two tasks, each rollout counted twice
    assert group["heldout"]["final"][0]["n"] == 2
    for name in (
        "er-resnet-t_success_matrix.png",
        "er-resnet-t_success_curves.png",
        "er-resnet-t_metrics.png",
    ):
        data = (tmp_path / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 2000
    assert "| er + resnet_t |" in (tmp_path / "report.md").read_text()


def test_replay(bench_run: Path, tmp_path: Path) -> None:
    listed = bench("replay", str(bench_run), "--task", "turn_on_the_stove")
    assert listed.returncode == 0, listed.stderr
    lines = listed.stdout.strip().splitlines()
    assert len(lines) == 6 and "k001-e000-t001-h000" in lines[0] and "k001-e000-t001-r000" in lines[1]
    out = tmp_path / "copy.rrd"
    result = bench("replay", str(bench_run), "--task", "0", "--rollout", "7", "--rrd", str(out))
    assert result.returncode == 0, result.stderr
    assert out.read_bytes() == (bench_run / "rrd" / "k001-z-t000-r000.rrd").read_bytes()
    bad = bench("replay", str(bench_run), "--task", "0", "--rollout", "9")
    assert bad.returncode == 2 and bad.stderr.strip() == (
        "error: task open_the_middle_drawer_of_the_cabinet has rollouts 0..8, not 9 (--rollout)"
    )


def test_saliency(bench_run: Path, tmp_path: Path) -> None:
    import rerun.recording as rd

    result = bench("saliency", str(bench_run), "--task", "1", "--frames", "0,20", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "frame_00000.png",
        "frame_00020.png",
        "saliency.rrd",
    ]
    from PIL import Image

    image = np.asarray(Image.open(tmp_path / "frame_00020.png"))
    assert image.shape[1] == 2 * image.shape[0]  # the frame and its overlay side by side
    recording = rd.load_recording(str(tmp_path / "saliency.rrd"))
    table = recording.view(index="frame", contents="/**").select().read_all()
    assert table.column("frame").to_pylist() == [0, 20]
    assert any(c.startswith("/saliency:") for c in table.column_names)
    from libero_bench.analysis.saliency_run import saliency_for_run

    # in this process: the 4th rollout of task 0 is the run's 4th episode (rollouts sort by key)
    written = saliency_for_run(bench_run, task="0", source="rollout", rollout=3, out=tmp_path / "r")
    length = _episodes(bench_run)[3]["length"]
    frames = sorted({round(float(x)) for x in np.linspace(0, length - 1, min(4, length))})
    assert [p.name for p in written] == [f"frame_{i:05d}.png" for i in frames] + ["saliency.rrd"]
    assert len(list((tmp_path / "r").glob("frame_*.png"))) >= 1


def test_robustness_sweep_of_a_smoke_policy(bench_run: Path, tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    # libero_goal/0 has no room for a distractor: those cells are reported, not run
    args = [
        "--tasks",
        "libero_goal/0",
        "--kinds",
        "camera,distractors",
        "--levels",
        "1,5",
        "--rollouts",
        "2",
    ]
    args += ["--max-steps", "5", "--workers", "2", "--out", str(out)]
    result = bench("robustness", str(bench_run), *args)
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads((out / "robustness.json").read_text())
    grid = summary["table"]["grid"]
    assert set(grid) == {"camera", "distractors"}
    assert grid["distractors"]["1"]["n"] == grid["distractors"]["5"]["n"] == 0
    reasons = {c["reason"] for c in summary["table"]["cells"] if c["kind"] == "distractors"}
    assert reasons == {"libero_goal/0: no room for a distractor"}
    assert "no room for a distractor" in (out / "robustness.md").read_text()
    for level in ("0", "1", "5"):
        entry = grid["camera"][level]
        assert entry["n"] == 2 and 0.0 <= entry["low"] <= entry["high"] <= 1.0
    cells = summary["table"]["cells"]
    assert sorted((c["kind"], c["level"]) for c in cells) == [
        ("", 0),
        ("camera", 1),
        ("camera", 5),
        ("distractors", 1),
        ("distractors", 5),
    ]
    # Every cell starts from the same held-out placements of the source task.
    rollouts = json.loads((out / "results.json").read_text())["rollouts"]
    seeds = {r["task"]: [x["env_seed"] for x in rollouts if x["task"] == r["task"]] for r in rollouts}
    assert len({tuple(s) for s in seeds.values()}) == 1 and len(rollouts) == 6
    # Stored like every evaluation: a LeRobot dataset of the rollouts, an MCAP log each.
    info = json.loads((out / "rollouts" / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 6
    assert (out / "robustness.png").stat().st_size > 10_000 and "| camera |" in (
        out / "robustness.md"
    ).read_text()
    # The variants are tasks of a suite folder that reproduces them.
    from libero_data.tasks import get_suite

    assert len(get_suite(out / "variants").tasks) == 3
    # Finished: the rollouts' shards are joined and gone (--keep-work keeps them), no hidden files.
    assert not (out / "shards").exists() and not list(out.rglob(".*"))
    again = bench("robustness", str(bench_run), *args)  # finished: nothing runs again
    assert again.returncode == 0 and json.loads((out / "robustness.json").read_text()) == summary
    assert json.loads((out / "rollouts" / "meta" / "info.json").read_text())["total_episodes"] == 6


def test_a_run_killed_in_the_middle_of_a_task_goes_on_with_the_same_results(
    bench_run: Path, tiny_dataset: Path, tmp_path: Path
) -> None:
    out = tmp_path / "resumed"
    command = [sys.executable, "-m", "libero_bench.cli", "run", "--data", str(tiny_dataset), *RUN_ARGS]
    # Two environments, as bench_run: the policy's batched pass is then the same, bit for bit
    # (another batch size may change the actions' last bits: docs/evaluation.md, "Which outcomes may differ").
    command += ["--workers", "2", "--out", str(out)]
    timings = out / "timings.jsonl"
    # Killed once the first task's epoch 1 of 2 has finished: its state (or epoch 0's) is on disk.
    kill_once(command, lambda: timings.is_file() and "epoch 1/2" in timings.read_text(), "epoch 1")
    partial = _results(out)
    assert not partial["complete"] and partial["stage"] == ["", ""]
    state = out / "checkpoints" / "task_000.epoch.safetensors"
    assert state.is_file() and not (out / "checkpoints" / "task_000.safetensors").exists()

    result = bench("run", "--data", str(tiny_dataset), *RUN_ARGS, "--workers", "2", "--out", str(out))
    assert result.returncode == 0, result.stderr[-3000:]
    assert "resuming after epoch" in (out / "run.log").read_text()
    assert not state.exists()  # the task ended: its epoch state is gone
    # Interrupted or not: the same numbers, rollouts, recordings and weights (checkpoints are the
    # same bytes for the same state).
    assert _results(out) == _results(bench_run)
    assert sorted(p.name for p in (out / "rrd").iterdir()) == sorted(
        p.name for p in (bench_run / "rrd").iterdir()
    )
    assert _episodes(out) == _episodes(bench_run)
    for k in range(2):
        name = f"task_{k:03d}.safetensors"
        assert (out / "checkpoints" / name).read_bytes() == (bench_run / "checkpoints" / name).read_bytes()
    resumed = json.loads((out / "config.json").read_text())["runtime"]["machines"]
    assert len(resumed) == 1  # the same machine worked on it twice: listed once
    import datasets

    ours = datasets.load_dataset(str(out / "rollouts"), split="train")
    theirs = datasets.load_dataset(str(bench_run / "rollouts"), split="train")
    for column in ("action", "observation.state", "libero.sim_state"):
        np.testing.assert_array_equal(np.array(ours[column]), np.array(theirs[column]))
    assert not list((out / ".work").glob("**/*.tmp-*"))

    # the same folder with other settings is refused, in one sentence
    other = bench("run", "--data", str(tiny_dataset), *RUN_ARGS, "--set", "batch_size=4", "--out", str(out))
    assert other.returncode == 2
    assert other.stderr.strip() == (
        f"error: {out} holds a run with a different 'preset'; resume it with the same settings "
        "or choose a new run folder"
    )


@pytest.mark.slow  # Ray starts in ~a minute; scripts/test runs it after the default suite
def test_ray_executor_gives_the_same_results(bench_run: Path, tiny_dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "on_ray"
    args = ["run", "--data", str(tiny_dataset), *RUN_ARGS, "--executor", "ray", "--workers", "2"]
    result = bench(*args, "--out", str(out))
    assert result.returncode == 0, result.stderr[-3000:]
    # Rollouts on Ray actors or in local worker processes: the same success numbers, episodes,
    # recordings and rollout data.
    assert _results(out) == _results(bench_run)
    assert _episodes(out) == _episodes(bench_run)
    assert sorted(p.name for p in (out / "rrd").iterdir()) == sorted(
        p.name for p in (bench_run / "rrd").iterdir()
    )
    import datasets

    ours = datasets.load_dataset(str(out / "rollouts"), split="train")
    theirs = datasets.load_dataset(str(bench_run / "rollouts"), split="train")
    for column in ("action", "observation.state", "libero.sim_state"):
        np.testing.assert_array_equal(np.array(ours[column]), np.array(theirs[column]))
    assert not list((out / ".work").glob("**/*.tmp*"))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--data", "{missing}"], "does not exist"),
        (
            ["--data", "{data}", "--algo", "sgd"],
            "unknown algorithm 'sgd'; known: er, ewc, mtl, packnet, seql",
        ),
        (["--data", "{data}", "--tasks", "put_the_bowl"], "has no task 'put_the_bowl'"),
        (["--data", "{data}", "--order", "3"], "upstream task orders are for 10 tasks, but the run has 2"),
        (["--data", "{data}", "--set", "epoch=3"], "the preset has no field 'epoch'"),
        (["--data", "{data}", "--set", "epochs=0"], "TrainPreset.epochs must be a positive integer"),
        (
            ["--data", "{data}", "--algo", "ewc", "--algo-set", "lam=5"],
            "the ewc algorithm has no field 'lam'; fields: fisher_batches, gamma, penalty_weight (--algo-set)",
        ),
        (
            ["--data", "{data}", "--algo", "ewc", "--algo-set", "penalty_weight=-1"],
            "EWCConfig.penalty_weight must be >= 0",
        ),
        (["--data", "{data}", "--device", "tpu"], "the device must be cpu or cuda, got 'tpu' (--device)"),
    ],
)
def test_bad_run_input_is_one_sentence(
    args: list[str], message: str, tiny_dataset: Path, tmp_path: Path
) -> None:
    filled = [a.format(missing=tmp_path / "nope", data=tiny_dataset) for a in args]
    result = bench("run", *filled, "--out", str(tmp_path / "run"), timeout=120)
    assert result.returncode == 2, result.stderr
    assert message in result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert not (tmp_path / "run" / "results.json").exists()


def test_bad_report_and_replay_input(tmp_path: Path, bench_run: Path) -> None:
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "x.txt").write_text("x")
    cases = [
        (["report", str(tmp_path / "junk")], "is not a libero-bench run folder"),
        (["report", str(tmp_path / "none")], "does not exist"),
        (["replay", str(bench_run), "--task", "stove"], "the run has no task 'stove'"),
        (["saliency", str(bench_run), "--task", "0", "--frames", "0,x"], "--frames takes comma-separated"),
        (["saliency", str(bench_run), "--task", "0", "--frames", "999"], "not 999"),
        (["run", "--data", str(bench_run / "rollouts"), "--out", str(tmp_path / "junk")], "is not empty"),
    ]
    for args, message in cases:
        result = bench(*args, timeout=120)
        assert result.returncode == 2, (args, result.stderr)
        assert message in result.stderr, (args, result.stderr)
        assert "Traceback" not in result.stderr


def test_a_run_resumed_on_another_make_of_cpu_lists_both_machines() -> None:
    # Machines of one numeric key replay the same rollouts, but torch trains a little differently
    # on another processor: a run carried from an Intel to an AMD machine says it worked on both.
    from libero_bench.train.plan import machines_worked

    intel = {"numeric_key": "6821d49cc09e", "cpu": "Intel(R) Xeon(R) Processor", "cpu_vendor": "GenuineIntel"}
    amd = {"numeric_key": "6821d49cc09e", "cpu": "AMD EPYC", "cpu_vendor": "AuthenticAMD"}
    assert machines_worked([intel], [dict(intel)]) == [intel]
    assert machines_worked([intel], [amd]) == [intel, amd]
    assert machines_worked([intel, amd], [dict(intel)]) == [intel, amd]
    other_key = {**intel, "numeric_key": "0123456789ab"}
    assert machines_worked([intel], [other_key]) == [intel, other_key]
