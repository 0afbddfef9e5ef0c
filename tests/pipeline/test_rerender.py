"""One expert run, every image size and naming: a dataset rendered again from its stored states,
and LeRobot's LIBERO naming profile."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from libero_data.pipeline.request import GenerateRequest
from libero_data.pipeline.validate import validate
from libero_data.record.features import OBS_IMAGE2, OBS_WRIST_IMAGE, dataset_features
from tests.pipeline.conftest import data_table, run_cli


def _policy_features(features: dict) -> dict[str, tuple[str, tuple[int, ...]]]:
    """What LeRobot's policies read from a dataset: name -> (type, shape)."""
    from lerobot.utils.feature_utils import dataset_to_policy_features

    return {k: (f.type.name, tuple(f.shape)) for k, f in dataset_to_policy_features(features).items()}


def _lerobot_libero_env_features(size: int) -> dict[str, tuple[str, tuple[int, ...]]]:
    """What LeRobot's LIBERO environment gives a policy (after its LIBERO processor step)."""
    from lerobot.envs.configs import LiberoEnv
    from lerobot.envs.utils import env_to_policy_features
    from lerobot.processor import LiberoProcessorStep

    grouped: dict = {}
    for key, feature in env_to_policy_features(
        LiberoEnv(observation_height=size, observation_width=size)
    ).items():
        grouped.setdefault(feature.type, {})[key] = feature
    processed = LiberoProcessorStep().transform_features(grouped)
    return {k: (f.type.name, tuple(f.shape)) for group in processed.values() for k, f in group.items()}


def test_the_lerobot_naming_profile_names_what_lerobots_libero_env_gives_a_policy() -> None:
    ours = GenerateRequest("libero_goal", (0,), image_size=256, features="lerobot-libero")
    policy_view = _policy_features(dataset_features(ours.layout, 79))
    expected = _lerobot_libero_env_features(256)
    assert {k: policy_view[k] for k in expected} == expected
    default = dataset_features(GenerateRequest("libero_goal", (0,)).layout, 79)
    assert OBS_WRIST_IMAGE in default and OBS_IMAGE2 not in default


@pytest.mark.sim
def test_rerender_gives_the_same_episodes_at_256_with_lerobots_names_and_fast_images(
    tiny_dataset: Path, tmp_path: Path
) -> None:
    """One re-render (2 workers) checked for what any re-render keeps (the episodes), for the
    naming profile and size asked, and for the render quality asked with its measured difference."""
    from libero_data.sim.fast.images import FAST_MEAN_BOUND

    out = tmp_path / "big"
    args = ["--features", "lerobot-libero", "--render-quality", "fast"]
    result = run_cli("rerender", str(tiny_dataset), "--out", str(out), *args, "--workers", "2")
    assert result.returncode == 0, result.stderr[-3000:]
    report = validate(out, resimulate=1)
    assert not report.issues and report.resimulated_ok == 1
    # The same episodes: actions and states frame by frame, in the same order.
    ours, theirs = data_table(out), data_table(tiny_dataset)
    for column in ("action", "libero.sim_state", "observation.state", "episode_index", "task_index"):
        assert np.array_equal(np.array(ours[column].to_pylist()), np.array(theirs[column].to_pylist())), (
            column
        )
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["features"][OBS_IMAGE2]["shape"] == [256, 256, 3] and OBS_WRIST_IMAGE not in info["features"]
    expected = _lerobot_libero_env_features(256)
    policy_view = _policy_features(info["features"])
    assert {k: policy_view[k] for k in expected} == expected
    card = (out / "README.md").read_text()
    assert (
        f"Re-rendered from the stored states of `{tiny_dataset}`" in card
        and "`observation.images.image2`" in card
    )
    # The render quality asked, stated with the difference measured against `full`.
    meta = json.loads((out / "meta" / "libero.json").read_text())
    render = meta["render"]
    assert render["quality"] == "fast" and meta["request"]["render_quality"] == "fast"
    assert set(render["difference"]) == {"agentview", "eye_in_hand"}
    for camera, d in render["difference"].items():
        assert d["frames"] == 4 and 0.0 < d["mean_abs"] <= FAST_MEAN_BOUND, (camera, d)
    rows = [json.loads(line) for line in (out / "meta" / "libero_episodes.jsonl").read_text().splitlines()]
    assert {row["render_quality"] for row in rows} == {"fast"}
    assert "fast: simplified visual meshes" in card and "agentview mean 0.00" in card
    assert "drawn at `fast` render quality" in card and "pixel for pixel" not in card
    source = json.loads((tiny_dataset / "meta" / "libero.json").read_text())
    assert source["render"] == {"quality": "full"}
    assert "full: LIBERO's own renderer, pixel for pixel" in (tiny_dataset / "README.md").read_text()
    # Finished: the dataset only, and the same command again has nothing to do.
    assert not (out / ".libero-data").exists()
    again = run_cli("rerender", str(tiny_dataset), "--out", str(out), *args)
    assert again.returncode == 0 and "done: 2 episodes" in again.stdout, again.stderr[-2000:]
    other = run_cli("rerender", str(tiny_dataset), "--out", str(out), "--image-size", "64")
    assert other.returncode == 2 and "different settings" in other.stderr
