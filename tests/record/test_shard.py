"""Writing one episode as a shard: every camera frame reaches the video, or nothing is written."""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import pytest

from libero_data.record import shard
from libero_data.record.features import FeatureLayout


def _frames(n: int, size: int = 32) -> list[dict]:
    rng = np.random.default_rng(0)
    frames = []
    for t in range(n):
        frames.append(
            {
                "sim_state": rng.normal(size=12),
                "state": rng.normal(size=8),
                "joint_pos": rng.normal(size=7),
                "gripper_state": rng.normal(size=2),
                "eef_pos": rng.normal(size=3),
                "eef_quat": np.array([1.0, 0.0, 0.0, 0.0]),
                "agentview": rng.integers(0, 255, (size, size, 3), dtype=np.uint8),
                "eye_in_hand": np.full((size, size, 3), t * 9 % 255, dtype=np.uint8),
                "action": rng.uniform(-1, 1, 7).astype(np.float32),
            }
        )
    return frames


def _write(out: Path, frames: list[dict]) -> Path:
    return shard.write_frames(
        out,
        frames=frames,
        success=[False] * (len(frames) - 1) + [True],
        task="synthetic",
        instruction="do nothing",
        layout=FeatureLayout(image_size=32),
        sim_state_width=12,
        info={"seed": 0},
    )


def test_every_frame_is_in_both_videos(tmp_path: Path) -> None:
    out = _write(tmp_path / "ep", _frames(40))
    videos = sorted(out.glob("videos/**/*.mp4"))
    assert len(videos) == 2
    for video in videos:
        with av.open(str(video)) as container:
            assert sum(1 for _ in container.decode(video=0)) == 40


def test_a_dropped_frame_fails_the_write_and_leaves_nothing(tmp_path: Path, monkeypatch) -> None:
    from libero_data.record.encoder import EpisodeVideoEncoder

    feed = EpisodeVideoEncoder.feed_frame
    calls = {"n": 0}

    def dropping(self, video_key: str, image: np.ndarray) -> None:  # a frame lost on the way
        calls["n"] += 1
        if calls["n"] != 7:
            feed(self, video_key, image)

    monkeypatch.setattr(EpisodeVideoEncoder, "feed_frame", dropping)
    with pytest.raises(RuntimeError, match="expected 20"):
        _write(tmp_path / "ep", _frames(20))
    assert list(tmp_path.iterdir()) == []
