"""generate -> load through both loaders; the card, the MCAP logs and our metadata."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import datasets
import numpy as np
import pytest
import torch
import yaml

from libero_data.record.features import (
    ACTION,
    OBS_IMAGE,
    OBS_STATE,
    OBS_WRIST_IMAGE,
    SIM_STATE,
    SIM_STATE_DIM,
    sim_states,
)

pytestmark = pytest.mark.sim

LANGUAGES = {"open the middle drawer of the cabinet", "turn on the stove"}


def test_load_dataset_reads_the_frames(tiny_dataset: Path) -> None:
    import datasets

    frames = datasets.load_dataset(str(tiny_dataset), split="train")
    info = json.loads((tiny_dataset / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 2 and len(frames) == info["total_frames"] > 50
    row = frames[0]
    assert len(row[OBS_STATE]) == 8 and len(row[ACTION]) == 7
    assert set(frames.unique("episode_index")) == {0, 1}
    assert set(frames.unique("task_index")) == {0, 1}


def test_lerobot_dataset_gives_decoded_frames_with_language(tiny_dataset: Path) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("libero-data/libero_goal", root=tiny_dataset)
    assert ds.num_episodes == 2 and ds.fps == 20
    first, last = ds[0], ds[len(ds) - 1]
    for item in (first, last):
        assert item["task"] in LANGUAGES
        for key in (OBS_IMAGE, OBS_WRIST_IMAGE):
            image = item[key]
            assert tuple(image.shape) == (3, 64, 64)
            assert float(image.min()) >= 0.0 and float(image.max()) <= 1.0 and float(image.std()) > 0.02
    assert first["task"] != last["task"]
    dim = int(first[SIM_STATE_DIM])
    assert 50 < dim <= first[SIM_STATE].shape[0]
    assert np.all(first[SIM_STATE].numpy()[dim:] == 0)
    # Through LeRobotDataset as through datasets: the MuJoCo state exactly (float64 bit for bit).
    assert first[SIM_STATE].dtype == torch.int64
    table = datasets.load_dataset(str(tiny_dataset), split="train")
    np.testing.assert_array_equal(sim_states(first[SIM_STATE]), sim_states([table[0][SIM_STATE]]).reshape(-1))
    assert np.all(np.isfinite(sim_states(first[SIM_STATE]))) and np.any(
        sim_states(first[SIM_STATE])[:dim] != 0
    )


def test_lerobot_makes_only_what_a_libero_policy_reads_its_inputs(tiny_dataset: Path) -> None:
    """LeRobot makes every observation.* column an input of the policy it trains (issue 75): ours are
    the two cameras and the 8-D state, what openpi's LIBERO request carries; the rest is libero.*."""
    from lerobot.utils.feature_utils import dataset_to_policy_features

    features = json.loads((tiny_dataset / "meta" / "info.json").read_text())["features"]
    for spec in features.values():
        spec["shape"] = tuple(spec["shape"])
    inputs = {k for k, f in dataset_to_policy_features(features).items() if f.type.name != "ACTION"}
    assert inputs == {OBS_IMAGE, OBS_WRIST_IMAGE, OBS_STATE}
    assert {
        "libero.joint_positions",
        "libero.gripper_state",
        "libero.eef_pose",
        SIM_STATE,
        SIM_STATE_DIM,
    } <= set(features)


def test_card_has_hugging_face_metadata_and_the_task_table(tiny_dataset: Path) -> None:
    text = (tiny_dataset / "README.md").read_text()
    assert text.startswith("---\n")
    header = yaml.safe_load(text.split("---\n")[1])
    assert header["license"] == "mit"
    assert header["task_categories"] == ["robotics"]
    assert header["configs"][0]["data_files"] == "data/*/*.parquet"
    info = json.loads((tiny_dataset / "meta" / "info.json").read_text())
    data_bytes = sum(p.stat().st_size for p in (tiny_dataset / "data").rglob("*.parquet"))
    assert header["dataset_info"]["splits"] == [
        {"name": "train", "num_examples": info["total_frames"], "num_bytes": data_bytes}
    ]
    assert "LeRobot" in header["tags"]
    for needle in (
        "open the middle drawer of the cabinet",
        "(Open wooden_cabinet_1_middle_region)",
        "(Turnon flat_stove_1)",
        "version: mujoco",
        "| seed | 3 |",
        "| starts | LIBERO's placement sampler, demonstration seeds (no stored init state); sampler starts: arm joints + N(0, 0.02 rad) |",
        "No episode starts from LIBERO's 50 stored init states",
    ):
        assert needle in text
    meta = json.loads((tiny_dataset / "meta" / "libero.json").read_text())
    assert meta["complete"] is True and meta["request"]["seed"] == 3
    assert set(meta["versions"]) >= {"mujoco", "robosuite", "lerobot", "libero-data"}
    from libero_data.provenance import expert_code

    assert meta["expert_code"] == [expert_code()]
    assert f"| expert code | {expert_code()} |" in text
    # The episodes' lengths, beside LIBERO's longest human demonstration of the suite.
    episodes = (tiny_dataset / "meta" / "libero_episodes.jsonl").read_text().splitlines()
    lengths = sorted(int(json.loads(line)["length"]) for line in episodes)
    assert f"longest {lengths[-1]} (LIBERO's longest human demonstration of libero_goal: 270) |" in text


def test_episode_metadata_and_bddl_are_stored(tiny_dataset: Path) -> None:
    rows = [
        json.loads(line)
        for line in (tiny_dataset / "meta" / "libero_episodes.jsonl").read_text().splitlines()
    ]
    assert [r["episode_index"] for r in rows] == [0, 1]
    assert [r["task_name"] for r in rows] == ["open_the_middle_drawer_of_the_cabinet", "turn_on_the_stove"]
    # Demonstrations start from LIBERO's sampler (seeded), never from a stored init state.
    assert all(r["success"] and r["init_index"] == -1 for r in rows)
    assert len({r["reset_seed"] for r in rows}) == len(rows)
    from libero_data.provenance import expert_code

    assert {r["expert_code"] for r in rows} == {expert_code()}
    assert sorted(p.name for p in (tiny_dataset / "meta" / "bddl").iterdir()) == [
        "open_the_middle_drawer_of_the_cabinet.bddl",
        "turn_on_the_stove.bddl",
    ]


def test_mcap_logs_have_every_channel(tiny_dataset: Path) -> None:
    from libero_data.pipeline.request import AFTER_GOAL
    from libero_data.record.mcap_log import read_mcap

    rows = [
        json.loads(line)
        for line in (tiny_dataset / "meta" / "libero_episodes.jsonl").read_text().splitlines()
    ]
    for row in rows:
        messages = list(read_mcap(tiny_dataset / "mcap" / f"episode_{row['episode_index']:06d}.mcap"))
        topics = {t for t, _, _ in messages}
        assert topics == {
            "/camera/agentview",
            "/camera/eye_in_hand",
            "/state",
            "/action",
            "/language",
            "/success",
        }
        actions = [m for t, _, m in messages if t == "/action"]
        assert len(actions) == row["length"]
        success = [m["success"] for t, _, m in messages if t == "/success"]
        reached = row["goal_step"] - 1  # the step the goal is first reached, held for the 10 after it
        assert len(success) - row["goal_step"] == AFTER_GOAL
        assert all(success[reached:]) and not any(success[:reached])
        image = next(m for t, _, m in messages if t == "/camera/agentview")
        assert image["format"] == "jpeg" and len(image["data"]) > 100
        language = next(m for t, _, m in messages if t == "/language")
        assert language["instruction"] == row["language"]


def test_bad_input_fails_cleanly(tmp_path: Path) -> None:
    from tests.pipeline.conftest import run_cli

    for args, message in [
        (("--suite", "libero_gaol"), "unknown suite 'libero_gaol'"),
        (("--suite", "libero_goal", "--tasks", "12"), "suite libero_goal has tasks 0..9, not 12"),
    ]:
        result = run_cli("generate", *args, "--out", str(tmp_path / "x"), timeout=120)
        assert result.returncode == 2
        assert message in result.stderr and "Traceback" not in result.stderr
        assert not (tmp_path / "x").exists(), "bad input leaves nothing behind"
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    result = run_cli(
        "generate",
        "--suite",
        "libero_goal",
        "--tasks",
        "7",
        "-n",
        "1",
        "--out",
        str(tmp_path / "busy"),
        timeout=120,
    )
    assert result.returncode == 2 and "not empty" in result.stderr


@pytest.mark.xdist_group("procedural")  # with the other readers of the shared procedural suite
def test_load_dataset_reads_a_dataset_regenerated_at_the_same_path(
    tiny_dataset: Path, procedural_suite: Path, tmp_path: Path
) -> None:
    # `datasets` caches a folder's frames under a key taken from the card's YAML header; the
    # header carries the frame count so that a new dataset in the same place is not read
    # from the old one's cache.
    import shutil

    import datasets

    here = tmp_path / "d"
    for source in (tiny_dataset, procedural_suite, tiny_dataset):
        if here.exists():
            shutil.rmtree(here)
        shutil.copytree(source, here, ignore=shutil.ignore_patterns(".libero-data"))
        frames = datasets.load_dataset(str(here), split="train")
        assert len(frames) == json.loads((here / "meta" / "info.json").read_text())["total_frames"]


def test_a_worker_keeps_its_environment_between_jobs_of_the_same_task() -> None:
    # Jobs are chunks of one task's episodes: building a LIBERO environment for each chunk
    # cost seconds and, measured, ~290 MiB the first time a process built a second one.
    from libero_data.pipeline.episodes import expert_env
    from libero_data.runtime.jobs import WorkerCache
    from libero_data.tasks import get_task

    cache = WorkerCache()
    first, other = get_task("libero_goal/0"), get_task("libero_goal/7")
    env, expert = expert_env(cache, first, 64)
    assert expert_env(cache, first, 64) == (env, expert)  # the next job of the same task: kept
    env2, _ = expert_env(cache, other, 64)  # another task: the old one is closed, a new one built
    assert env2 is not env and "_env" not in vars(env)
    assert expert_env(cache, first, 96)[0] is not env2  # another image size: rebuilt too
    cache.close()
    cache.close()  # closing twice is harmless


def test_an_episode_is_reported_only_once_its_shard_is_on_disk(tiny_dataset: Path, tmp_path: Path) -> None:
    """Shards are completed in a background thread while the next episode renders; two
    episodes of one task (the stored search of task 0, used twice) go through that path."""
    import dataclasses
    import shutil

    from libero_data.pipeline.episodes import EpisodeJob, make_episodes
    from libero_data.pipeline.request import GenerateRequest
    from libero_data.runtime.jobs import WorkerCache, WorkerContext

    source = tiny_dataset / ".libero-data"
    work = tmp_path / "work"
    (work / "search").mkdir(parents=True)
    record = next((source / "search").glob("000-00000*"))
    for k in (0, 1):
        shutil.copy(record, work / "search" / record.name.replace("000-00000", f"000-{k:05d}"))
    request = GenerateRequest.from_dict(json.loads((source / "request.json").read_text()))
    # `fast` images: the background writer is under test here, not the renderer (3x cheaper)
    request = dataclasses.replace(request, render_quality="fast")
    width = int(json.loads((source / "sim_state_width.json").read_text()))
    on_disk: list[tuple[str, bool]] = []

    def report(done: Any) -> None:
        shard = work / "shards" / done.key
        on_disk.append(
            (
                done.key,
                done.success and (shard / "episode.json").is_file() and (shard / "episode.mcap").is_file(),
            )
        )

    cache = WorkerCache()
    ctx = WorkerContext(work, cache, None, report)
    try:
        finished = make_episodes(ctx, EpisodeJob(request, 0, request.tasks[0], (0, 1), width))
    finally:
        cache.close()
    assert [(d.k, d.success) for d in finished] == [(0, True), (1, True)]
    assert on_disk == [("000-00000", True), ("000-00001", True)]
    assert not [p for p in (work / "shards").iterdir() if ".tmp" in p.name]
    first, second = (work / "shards" / key for key, _ in on_disk)
    ours = sorted(p.relative_to(first) for p in first.rglob("*") if p.is_file())
    assert ours == sorted(p.relative_to(second) for p in second.rglob("*") if p.is_file())
    for rel in ours:  # same episode rendered twice, through the background writer each time
        if rel.suffix in (".mp4", ".parquet"):
            assert (first / rel).read_bytes() == (second / rel).read_bytes(), rel


def test_no_episode_the_card_calls_usable_exceeds_the_length_bound(tmp_path: Path) -> None:
    """Two episodes of turning on the stove (about 95 steps: 88-127 over the 50 stored starts of
    the expert report) under a 91-step bound: attempts longer than it are failed attempts; whatever
    the search found, nothing kept is longer, and the card and metadata count what was stopped."""
    from libero_data.pipeline.generate import generate
    from libero_data.pipeline.resolve import resolve_request
    from libero_data.pipeline.sources import EpisodeRecord

    bound = 91
    request = resolve_request(
        "libero_goal", ["7"], episodes_per_task=2, image_size=32, seed=5, max_length=bound
    ).replace(cameras=("agentview",))
    out = tmp_path / "bounded"
    progress = generate(request, out, keep_work=True)
    records = [EpisodeRecord.load(p) for p in sorted((out / ".libero-data" / "search").glob("*.npz"))]
    assert len(records) == 2 and progress.done + progress.failed == 2
    rows = [json.loads(line) for line in (out / "meta" / "libero_episodes.jsonl").read_text().splitlines()]
    assert len(rows) == sum(r.success for r in records) == progress.done
    assert all(int(row["length"]) <= bound for row in rows)
    meta = json.loads((out / "meta" / "libero.json").read_text())
    assert meta["request"]["max_length"] == bound
    (task,) = meta["tasks"]
    stopped = sum(r.too_long for r in records)
    assert task["length_bound"] == bound and task["attempts_stopped_at_bound"] == stopped
    assert task["standard_limit"] == 300 and task["within_standard_limit"] == len(rows)
    card = (out / "README.md").read_text()
    assert f"| length bound (steps) | {bound} steps (`--max-length {bound}`) |" in card
    assert (
        f"What it cost: {stopped} of {sum(r.attempts for r in records)} attempts stopped at the bound" in card
    )
    if rows:
        assert "![Episode lengths against the standard limit](meta/episode_lengths.png)" in card
        assert (out / "meta" / "episode_lengths.png").read_bytes().startswith(b"\x89PNG")
        assert f"{len(rows)} of {len(rows)} (100%) within the limit" in card
