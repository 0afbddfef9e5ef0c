"""The episode video encoder: LeRobot's videos and statistics, exact, and no frame ever dropped."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from types import SimpleNamespace

import av
import numpy as np
import pandas as pd
import pytest

from libero_data.record import encoder

from .test_shard import _frames, _write


def test_uint8_statistics_are_exact() -> None:
    rng = np.random.default_rng(3)
    pixels = np.stack([rng.integers(10, 200, 5000), rng.binomial(255, 0.3, 5000), np.full(5000, 7)], axis=1)
    counts = np.stack([np.bincount(pixels[:, c], minlength=256) for c in range(3)])
    stats = encoder.uint8_statistics(counts)
    np.testing.assert_array_equal(stats["min"], pixels.min(axis=0))
    np.testing.assert_array_equal(stats["max"], pixels.max(axis=0))
    np.testing.assert_allclose(stats["mean"], pixels.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(stats["std"], pixels.std(axis=0), rtol=1e-9, atol=1e-9)
    assert stats["count"].tolist() == [5000]
    for q in encoder.QUANTILES:
        expected = np.quantile(pixels, q, axis=0, method="inverted_cdf")
        np.testing.assert_array_equal(stats[f"q{round(q * 100):02d}"], expected)
    with pytest.raises(ValueError, match="no pixels"):
        encoder.uint8_statistics(np.zeros((3, 256)))


def test_a_short_queue_waits_instead_of_dropping(tmp_path: Path) -> None:
    frames = [np.full((16, 16, 3), 8 * t, dtype=np.uint8) for t in range(30)]
    streams = encoder.EpisodeVideoEncoder(fps=20, maxsize=2)
    streams.start_episode(["cam"], tmp_path)
    for frame in frames:
        streams.feed_frame("cam", frame)
    (path, stats) = streams.finish_episode()["cam"]
    with av.open(str(path)) as container:
        decoded = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    assert len(decoded) == 30
    assert stats is not None and stats["count"].tolist() == [30 * 16 * 16]
    assert abs(float(decoded[-1].mean()) - 232) < 4  # frames arrive in order


def _keyframes(frames: list[np.ndarray], tmp_path: Path, spacing: int) -> tuple[list[int], list[np.ndarray]]:
    """Where the key frames of the H.264 video of ``frames`` fall, and its decoded frames."""
    from lerobot.configs.video import RGBEncoderConfig

    config = RGBEncoderConfig(vcodec="h264", preset="veryfast", crf=20, g=40, pix_fmt="yuv420p")
    tmp_path.mkdir()
    streams = encoder.EpisodeVideoEncoder(fps=20, rgb_encoder=config, key_spacing=spacing)
    streams.start_episode(["cam"], tmp_path)
    for frame in frames:
        streams.feed_frame("cam", frame)
    (path, _stats) = streams.finish_episode()["cam"]
    with av.open(str(path)) as container:
        stamped = [(int(p.pts), p.is_keyframe) for p in container.demux(video=0) if p.pts is not None]
        keys = [i for i, (_pts, key) in enumerate(sorted(stamped)) if key]
    with av.open(str(path)) as container:
        decoded = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    return keys, decoded


def test_key_frames_start_where_the_images_are_new(tmp_path: Path) -> None:
    ramp = np.add.outer(np.arange(64), np.arange(64)).astype(np.uint8)
    image = lambda t: np.stack([ramp + 10 * t, ramp, np.full_like(ramp, 5 * t)], axis=2)  # noqa: E731
    # Images held for 5 frames (a policy executing 5 actions of each chunk): one key frame per
    # new image, none inside a hold.
    held = [image(t // 5) for t in range(20)]
    keys, decoded = _keyframes(held, tmp_path / "held", spacing=2)
    assert keys == [0, 5, 10, 15]
    assert len(decoded) == 20 and all(
        np.abs(d.astype(int) - f).mean() < 3 for d, f in zip(decoded, held, strict=True)
    )
    # A new image every frame: a key frame every 2 frames, as LeRobot's GOP of 2 puts them.
    assert _keyframes([image(t) for t in range(9)], tmp_path / "new", spacing=2)[0] == [0, 2, 4, 6, 8]
    # Held for one extra frame: the first new image 2 or more frames after the last key.
    assert _keyframes([image(t // 2) for t in range(8)], tmp_path / "pairs", spacing=2)[0] == [0, 2, 4, 6]


def test_bad_frames_and_encoder_failures_are_errors(tmp_path: Path) -> None:
    streams = encoder.EpisodeVideoEncoder(fps=20)
    streams.start_episode(["cam"], tmp_path)
    with pytest.raises(ValueError, match="uint8"):
        streams.feed_frame("cam", np.zeros((16, 16, 3), dtype=np.float32))
    streams.cancel_episode()
    assert list(tmp_path.iterdir()) == []  # cancelling removes the scratch video

    no_codec = SimpleNamespace(
        vcodec="no-such-codec", pix_fmt="yuv420p", get_codec_options=lambda *a, **k: {}
    )
    broken = encoder.EpisodeVideoEncoder(fps=20, rgb_encoder=no_codec)
    broken.start_episode(["cam"], tmp_path)
    with pytest.raises(RuntimeError, match="encoding cam failed"):
        for _ in range(5):
            broken.feed_frame("cam", np.zeros((16, 16, 3), dtype=np.uint8))
        broken.finish_episode()


def _flat(nested: object) -> list[float]:
    """Numbers of a parquet cell of nested object arrays, in order."""
    if isinstance(nested, np.ndarray | list):
        return [x for item in nested for x in _flat(item)]
    assert isinstance(nested, int | float | np.number), nested
    return [float(nested)]


def test_shards_match_what_lerobots_own_streaming_encoder_writes(tmp_path: Path, monkeypatch) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    frames = _frames(25)
    ours = _write(tmp_path / "ours", frames)
    monkeypatch.setattr(encoder, "shard_dataset_class", lambda key_spacing=None: LeRobotDataset)
    theirs = _write(tmp_path / "theirs", frames)
    videos = sorted(p.relative_to(ours) for p in ours.glob("videos/**/*.mp4"))
    assert len(videos) == 2
    for video in videos:  # same codec, settings and frames: the same bytes
        assert (
            hashlib.sha256((ours / video).read_bytes()).digest()
            == hashlib.sha256((theirs / video).read_bytes()).digest()
        )

    def image_stats(root: Path) -> dict[str, np.ndarray]:
        episodes = pd.read_parquet(next((root / "meta" / "episodes").rglob("*.parquet")))
        return {
            c: np.array(_flat(episodes[c].iloc[0]))
            for c in episodes.columns
            if c.startswith("stats/observation.images")
        }

    ours_stats, theirs_stats = image_stats(ours), image_stats(theirs)
    assert ours_stats.keys() == theirs_stats.keys() and len(ours_stats) == 20
    for key, value in ours_stats.items():  # LeRobot estimates quantiles from 5,000 bins; ours are exact
        np.testing.assert_allclose(value, theirs_stats[key], atol=1.5 / 255, err_msg=key)


def test_skipping_the_empty_image_embedding_writes_the_same_parquet(tmp_path: Path, monkeypatch) -> None:
    import pyarrow.parquet as pq
    from lerobot.datasets import dataset_writer, io_utils

    frames = _frames(25)
    ours = _write(tmp_path / "ours", frames)
    assert getattr(dataset_writer.embed_images, "wrapped_by_libero_data", False)
    called = []

    def lerobots(dataset):  # LeRobot's own, counted
        called.append(len(dataset))
        return io_utils.embed_images(dataset)

    monkeypatch.setattr(dataset_writer, "embed_images", lerobots)
    theirs = _write(tmp_path / "theirs", frames)
    assert called == [25]
    tables = sorted(p.relative_to(ours) for p in (ours / "data").rglob("*.parquet"))
    assert tables
    for table in tables:  # the same rows and schema; only `datasets`' cache fingerprint is gone
        a, b = (pq.read_table(root / table) for root in (ours, theirs))
        assert a.equals(b)
        meta_a, meta_b = (json.loads(t.schema.metadata[b"huggingface"]) for t in (a, b))
        assert meta_b.pop("fingerprint") and meta_a == meta_b
        assert a.schema.remove_metadata() == b.schema.remove_metadata()
    # A dataset with an image column still goes through LeRobot's embedding.
    import datasets

    monkeypatch.setattr(dataset_writer, "embed_images", lerobots)
    encoder.embed_only_what_needs_it()
    with_images = datasets.Dataset.from_dict(
        {"image": [np.zeros((4, 4, 3), np.uint8)]}, features=datasets.Features({"image": datasets.Image()})
    )
    dataset_writer.embed_images(with_images)
    assert called == [25, 1]
