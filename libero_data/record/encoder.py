"""Video encoding of an episode's camera frames while later frames are still rendering.

LeRobot's own streaming encoder (``StreamingVideoEncoder``) is made for live cameras: it drops
frames when its queue fills, and each of its threads keeps running image statistics in a
5,000-bin float histogram per channel, whose update converts every pixel of every frame to
float and bins it against float edges, and whose re-binning loops in Python whenever a frame
widens the value range. Those calls hold the GIL, so the rendering thread waits on them. Camera
frames are ``uint8``, so exact statistics need only a 256-bin integer count per channel, far
less work; :class:`EpisodeVideoEncoder` keeps that, blocks instead of dropping frames, and
otherwise hands LeRobot what its encoder would: one MP4 per camera (same codec and settings,
LeRobot's defaults) and the statistics in the same layout. What handing it frames costs is the
"encoding" stage of benchmarks/RESULTS.md, Generation. :class:`ShardDataset` is a
``LeRobotDataset`` that streams through it.
"""

from __future__ import annotations

import contextlib
import functools
import queue
import shutil
import tempfile
import threading
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)  # the keys LeRobot's stats carry: q01 ... q99
_DONE = object()


def uint8_statistics(counts: np.ndarray, quantiles: tuple[float, ...] = QUANTILES) -> dict[str, np.ndarray]:
    """Per-channel statistics of ``uint8`` pixels from their value counts (``counts[c, v]``).

    The layout of LeRobot's image statistics before normalisation: ``min``, ``max``, ``mean``,
    ``std`` and ``qNN`` per channel in pixel units, and ``count`` (pixels per channel). All are
    exact; a quantile is the smallest value whose cumulative share reaches it.
    """
    counts = np.asarray(counts, dtype=np.int64)
    total = counts.sum(axis=1)
    if (total == 0).any():
        raise ValueError("no pixels counted")
    values = np.arange(counts.shape[1], dtype=np.float64)
    present = counts > 0
    mean = counts @ values / total
    var = counts @ values**2 / total - mean**2
    cumulative = np.cumsum(counts, axis=1)
    stats: dict[str, np.ndarray] = {
        "min": np.argmax(present, axis=1).astype(np.float64),
        "max": (counts.shape[1] - 1 - np.argmax(present[:, ::-1], axis=1)).astype(np.float64),
        "mean": mean,
        "std": np.sqrt(np.maximum(var, 0.0)),
        "count": np.array([int(total[0])]),
    }
    for q in quantiles:
        reach = np.array([np.searchsorted(row, q * n) for row, n in zip(cumulative, total, strict=True)])
        stats[f"q{round(q * 100):02d}"] = reach.astype(np.float64)
    return stats


class _CameraThread(threading.Thread):
    """Encodes one camera's frames from a queue into an MP4 and counts its pixel values."""

    def __init__(
        self,
        path: Path,
        fps: int,
        config: Any,
        encoder_threads: int | None,
        maxsize: int,
        key_spacing: int | None = None,
    ):
        super().__init__(daemon=True, name=f"encode-{path.stem}")
        self.path = path
        self.key_spacing = key_spacing
        self.fps = fps
        self.config = config
        self.encoder_threads = encoder_threads
        self.frames: queue.Queue[Any] = queue.Queue(maxsize=maxsize)
        self.counts: np.ndarray | None = None
        self.written = 0
        self.error: BaseException | None = None
        self.cancelled = threading.Event()

    def run(self) -> None:
        import av

        container: Any = None
        stream: Any = None
        counts = np.zeros((0, 256), dtype=np.int64)  # replaced at the first frame
        previous: np.ndarray | None = None  # the frame before (only where keyframes follow new images)
        frame_counts: np.ndarray = np.zeros(
            (0, 256), dtype=np.int64
        )  # set at the first frame (never a repeat)
        last_key = 0
        try:
            while True:
                frame = self.frames.get()
                if frame is _DONE or self.cancelled.is_set():
                    break
                if container is None:
                    height, width = frame.shape[:2]
                    container = av.open(str(self.path), "w")
                    stream = container.add_stream(
                        self.config.vcodec,
                        self.fps,
                        options=self.config.get_codec_options(self.encoder_threads, as_strings=True),
                    )
                    stream.pix_fmt = self.config.pix_fmt
                    stream.width, stream.height = width, height
                    stream.time_base = Fraction(1, self.fps)
                    counts = self.counts = np.zeros((frame.shape[2], 256), dtype=np.int64)
                picture = av.VideoFrame.from_ndarray(frame, format="rgb24")
                # frames that repeat (a rollout's held images): the same image as the frame before
                repeat = previous is not None and (frame is previous or np.array_equal(frame, previous))
                if self.key_spacing is not None:
                    if previous is None or (self.written - last_key >= self.key_spacing and not repeat):
                        picture.pict_type = av.video.frame.PictureType.I
                        last_key = self.written
                    previous = frame
                picture.pts = self.written
                picture.time_base = Fraction(1, self.fps)
                container.mux(stream.encode(picture))
                if not repeat:  # a repeated image adds the counts of the one it repeats
                    flat = frame.reshape(-1, frame.shape[2])
                    frame_counts = np.stack(
                        [np.bincount(flat[:, c], minlength=256) for c in range(flat.shape[1])]
                    )
                counts += frame_counts
                self.written += 1
            if stream is not None and not self.cancelled.is_set():
                container.mux(stream.encode())
        except BaseException as exc:  # reported to the feeding thread
            self.error = exc
            self.cancelled.set()
            # Unblock a feeder waiting on a full queue.
            while not self.frames.empty():
                self.frames.get_nowait()
        finally:
            if container is not None:
                try:
                    container.close()  # a full disk fails here too: reported, never printed by the thread
                except BaseException as exc:
                    self.error = self.error or exc


def raise_failure(video_key: str, error: BaseException | None) -> None:
    """Raise what stopped a camera's encoding thread: the system's own error where the system
    failed (a full disk: ``libero_data.cli`` turns its errno into one sentence), else a
    RuntimeError naming the video."""
    if isinstance(error, OSError):
        raise error
    raise RuntimeError(f"encoding {video_key} failed: {error!r}")


class EpisodeVideoEncoder:
    """Streams each camera of an episode to its own encoding thread (LeRobot's streaming-encoder
    interface: ``start_episode``, ``feed_frame``, ``finish_episode``, ``cancel_episode``, ``close``).

    Frames must be ``uint8`` RGB, height × width × 3. A full queue makes ``feed_frame`` wait
    (an offline renderer can wait; a dropped frame would be a corrupt episode).

    ``key_spacing`` (for frames that repeat, as a rollout's held images do): a keyframe starts
    at the first new image at least that many frames after the last keyframe, and a repeated
    image never starts one; the codec's own GOP (``g``) should then be long, a cap only. With
    every image new, keyframes fall every ``key_spacing`` frames, as a codec GOP of that size
    puts them; with images held for a policy's chunk, one per new image instead of an intra
    frame every other frame of the hold (those cost most of the encoding). A frame decodes
    from its keyframe through at most ``key_spacing - 1`` frames plus repeats, which copy.
    """

    def __init__(
        self,
        fps: int,
        rgb_encoder: Any = None,
        encoder_threads: int | None = 1,
        maxsize: int = 64,
        key_spacing: int | None = None,
    ):
        from lerobot.datasets.video_utils import rgb_encoder_defaults

        self.key_spacing = key_spacing
        self.fps = fps
        self.config = rgb_encoder or rgb_encoder_defaults()
        self.encoder_threads = encoder_threads
        self.maxsize = maxsize
        self._threads: dict[str, _CameraThread] = {}
        self._scratch: list[Path] = []

    def start_episode(
        self, video_keys: list[str], temp_dir: Path, depth_video_keys: list[str] | None = None
    ) -> None:
        if depth_video_keys:
            raise ValueError(f"depth videos are not supported: {depth_video_keys}")
        self.cancel_episode()
        for key in video_keys:
            scratch = Path(tempfile.mkdtemp(dir=temp_dir))
            self._scratch.append(scratch)
            thread = _CameraThread(
                scratch / f"{key.replace('/', '_')}.mp4",
                self.fps,
                self.config,
                self.encoder_threads,
                self.maxsize,
                self.key_spacing,
            )
            thread.start()
            self._threads[key] = thread

    def feed_frame(self, video_key: str, image: np.ndarray) -> None:
        thread = self._threads[video_key]
        image = np.asarray(image)
        if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
            raise ValueError(f"{video_key}: expected uint8 H×W×3 frames, got {image.dtype} {image.shape}")
        while True:
            if thread.error is not None or not thread.is_alive():
                raise_failure(video_key, thread.error)
            try:
                thread.frames.put(image.copy(), timeout=1.0)
                return
            except queue.Full:
                continue

    def finish_episode(self) -> dict[str, tuple[Path, dict[str, np.ndarray] | None]]:
        """Flush every camera; {key: (mp4 path, pixel statistics)}."""
        for thread in self._threads.values():
            if thread.is_alive():  # a live thread drains its queue, so this put returns
                thread.frames.put(_DONE)
        results: dict[str, tuple[Path, dict[str, np.ndarray] | None]] = {}
        for key, thread in self._threads.items():
            thread.join()
            if thread.error is not None:
                raise_failure(key, thread.error)
            counts = thread.counts
            stats = uint8_statistics(counts) if counts is not None and thread.written >= 2 else None
            results[key] = (thread.path, stats)
        self._threads = {}
        self._scratch = []  # LeRobot moves the files out; its folder tidies the rest
        return results

    def cancel_episode(self) -> None:
        for thread in self._threads.values():
            thread.cancelled.set()
            with contextlib.suppress(queue.Full):
                thread.frames.put_nowait(_DONE)
        for thread in self._threads.values():
            thread.join()
        for scratch in self._scratch:
            shutil.rmtree(scratch, ignore_errors=True)
        self._threads = {}
        self._scratch = []

    def close(self) -> None:
        self.cancel_episode()


def embed_only_what_needs_it() -> None:
    """Make LeRobot's episode writer skip ``embed_images`` where no feature stores files.

    LeRobot runs ``datasets``' ``embed_table_storage`` over every row of each episode before
    writing its Parquet, to put image files' bytes into the table. Our shards keep images in
    videos, so no column needs it and each row comes back as it was, after ``datasets`` has
    rebuilt the features from the schema row by row, in Python, in every episode's store. This
    wraps the writer's ``embed_images``: unchanged where any feature needs embedding, the
    dataset itself where none does: the same rows and schema, less the ``fingerprint`` of
    ``datasets``' cache that the skipped ``map`` left in the Parquet's metadata
    (tests/record/test_encoder.py). Idempotent; called when a shard dataset is first made,
    never at import.
    """
    from datasets.features.features import require_storage_embed
    from lerobot.datasets import dataset_writer

    original = dataset_writer.embed_images
    if getattr(original, "wrapped_by_libero_data", False):
        return

    def embed_images(dataset: Any) -> Any:
        if any(require_storage_embed(feature) for feature in dataset.features.values()):
            return original(dataset)
        return dataset

    embed_images.wrapped_by_libero_data = True  # type: ignore[attr-defined]
    dataset_writer.embed_images = embed_images


@functools.cache
def shard_dataset_class(key_spacing: int | None = None) -> Any:
    """``LeRobotDataset`` streaming its videos through :class:`EpisodeVideoEncoder` (imported
    lazily), with keyframes placed by ``key_spacing`` where given."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    embed_only_what_needs_it()

    class ShardDataset(LeRobotDataset):
        @staticmethod
        def _build_streaming_encoder(
            fps: int,
            rgb_encoder: Any,
            depth_encoder: Any,
            encoder_queue_maxsize: int,
            encoder_threads: int | None,
        ) -> EpisodeVideoEncoder:
            return EpisodeVideoEncoder(
                fps, rgb_encoder, encoder_threads, maxsize=encoder_queue_maxsize, key_spacing=key_spacing
            )

    return ShardDataset
