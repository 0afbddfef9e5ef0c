"""Rendering one searched episode and writing it as a one-episode LeRobot dataset + MCAP.

An episode is searched without cameras; its states are then restored one by one and both
cameras rendered (the only expensive part). The shard is built in a temporary folder and
renamed into place, so a shard folder on disk is always complete.
"""

from __future__ import annotations

import contextlib
import json
import shutil
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.record.features import FeatureLayout, dataset_features, frame_from_observation
from libero_data.record.mcap_log import write_episode_mcap
from libero_data.runtime.files import commit_folder, scratch_folder

if TYPE_CHECKING:
    from libero_data.sim import LiberoEnv

FPS = 20
SHARD_REPO = "libero-data/shard"
MCAP_NAME = "episode.mcap"
INFO_NAME = "episode.json"


def render_frames(
    env: LiberoEnv,
    states: np.ndarray,
    actions: np.ndarray,
    final_state: np.ndarray,
    success: list[bool] | None = None,
    render: dict[str, Any] | None = None,
) -> Iterator[dict[str, Any]]:
    """Observations (with images) of every stored state, one at a time as they are rendered.

    ``success``, when given, receives whether the goal holds after each action, once the
    last frame has been taken. ``render``, when given, receives how the images were drawn
    (:meth:`LiberoEnv.render_scene`); for ``fast`` images also their measured difference from
    full-quality images of the episode's first and last frame (``difference``).
    """
    holds: list[bool] = []
    difference: dict[str, dict[str, float]] = {}
    measured = {0, len(states) - 1} if env.config.render_quality == "fast" else set()
    for i, (state, action) in enumerate(zip(states, actions, strict=True)):
        env.set_state(state)
        obs = env.observe(render=True)
        obs["action"] = np.asarray(action, dtype=np.float32)
        if i in measured:
            add_difference(difference, env, obs)
        holds.append(env.success())
        yield obs
    env.set_state(final_state)
    holds.append(env.success())
    if success is not None:
        success.extend(holds[1:])
    if render is not None:
        render.update(env.render_scene())
        if difference:
            render["difference"] = difference


def add_difference(totals: dict[str, dict[str, float]], env: LiberoEnv, obs: dict[str, Any]) -> None:
    """Add the per-pixel |fast - full| of this frame's images (0-255) to ``totals`` per camera:
    ``sum``, ``max``, the number of ``values`` compared and of ``frames``."""
    for camera in env.config.cameras:
        delta = np.abs(obs[camera].astype(np.int16) - env.render_full(camera).astype(np.int16))
        entry = totals.setdefault(camera, {"sum": 0.0, "max": 0.0, "values": 0.0, "frames": 0.0})
        entry["sum"] += float(delta.sum())
        entry["max"] = max(entry["max"], float(delta.max()))
        entry["values"] += float(delta.size)
        entry["frames"] += 1.0


def render_shard(
    out_dir: str | Path,
    *,
    env: LiberoEnv,
    states: np.ndarray,
    actions: np.ndarray,
    final_state: np.ndarray,
    task: str,
    instruction: str,
    layout: FeatureLayout,
    sim_state_width: int,
    info: dict[str, Any],
) -> Callable[[], Path]:
    """Render one searched episode from its states; returns the call that completes the shard.

    Each frame goes to the video encoder as soon as it is rendered, so encoding (in the
    encoder's threads) overlaps rendering instead of following it. When this returns, ``env``
    is free again; the returned call (flushing the videos, writing parquet and MCAP, moving the
    folder into place) needs no simulation and may run in another thread while the next
    episode is searched. Until it has run, nothing is at ``out_dir``.
    """
    success: list[bool] = []
    render: dict[str, Any] = {}
    # ``success``: whether the goal holds after the last action, as rendered (whatever the
    # source thought of the episode); set once every frame is in
    info = {**info, "success": False}
    if env.config.render_quality != "full":
        info["render"] = render  # filled in as the frames are rendered
    finish = _start(
        Path(out_dir),
        frames=render_frames(env, states, actions, final_state, success, render),
        length=len(states),
        success=success,
        task=task,
        instruction=instruction,
        layout=layout,
        sim_state_width=sim_state_width,
        info=info,
    )
    info["success"] = bool(success[-1])
    return finish


def write_frames(
    out_dir: str | Path,
    *,
    frames: Iterable[dict[str, Any]],
    success: list[bool],
    task: str,
    instruction: str,
    layout: FeatureLayout,
    sim_state_width: int,
    info: dict[str, Any],
    length: int | None = None,
    rgb_encoder: Any = None,
    key_spacing: int | None = None,
    jpegs: Callable[[np.ndarray], bytes] | None = None,
) -> Path:
    """Write observed frames (env observations with images and an ``action``) as a one-episode shard.

    Used for expert demonstrations (rendered from states) and for policy rollouts (rendered
    while acting). ``frames`` may be a list or an iterator (then ``length`` says how many it
    gives, and ``success`` may be filled in while it runs). The folder appears atomically: a
    LeRobot dataset, ``episode.mcap`` and ``episode.json`` (``info`` plus the length).
    ``rgb_encoder`` is LeRobot's ``RGBEncoderConfig`` of the videos (default: LeRobot's);
    ``key_spacing`` places keyframes by new images for frames that repeat
    (:class:`~libero_data.record.encoder.EpisodeVideoEncoder`); ``jpegs`` encodes the MCAP log's
    images (:func:`~libero_data.record.mcap_log.episode_jpegs`, shared with another log).
    """
    if length is None:
        frames = list(frames)
        length = len(frames)
    return _start(
        Path(out_dir),
        frames=frames,
        length=length,
        success=success,
        task=task,
        instruction=instruction,
        layout=layout,
        sim_state_width=sim_state_width,
        info=info,
        rgb_encoder=rgb_encoder,
        key_spacing=key_spacing,
        jpegs=jpegs,
    )()


def _start(
    out: Path,
    *,
    frames: Iterable[dict[str, Any]],
    length: int,
    success: list[bool],
    task: str,
    instruction: str,
    layout: FeatureLayout,
    sim_state_width: int,
    info: dict[str, Any],
    rgb_encoder: Any = None,
    key_spacing: int | None = None,
    jpegs: Callable[[np.ndarray], bytes] | None = None,
) -> Callable[[], Path]:
    """Feed every frame to a new shard in a scratch folder beside ``out``; returns the call
    that writes the rest and renames the folder to ``out`` (the scratch folder is removed if
    either part fails)."""
    from libero_data.record.encoder import shard_dataset_class

    tmp = scratch_folder(out)
    try:
        dataset = shard_dataset_class(key_spacing).create(
            SHARD_REPO,
            fps=FPS,
            features=dataset_features(layout, sim_state_width),
            root=tmp,
            robot_type="panda",
            use_videos=True,
            rgb_encoder=rgb_encoder,
            # Frames go straight to an encoder thread per camera instead of through a PNG per
            # frame and camera (libero_data.record.encoder: LeRobot's codec settings, exact
            # uint8 statistics, a bounded queue that waits rather than drops); the videos are
            # still checked below.
            streaming_encoding=True,
            encoder_threads=1,
            encoder_queue_maxsize=64,
        )
        kept: list[dict[str, Any]] = []
        for obs in frames:
            frame = frame_from_observation(obs, obs["action"], sim_state_width, layout)
            frame["task"] = instruction
            dataset.add_frame(frame)
            kept.append(obs)
        if len(kept) != length:
            raise ValueError(f"expected {length} frames, got {len(kept)}")
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise

    def finish() -> Path:
        try:
            with quiet_datasets():
                dataset.save_episode(parallel_encoding=False)
                dataset.finalize()
            _check_video_lengths(tmp, length)
            write_episode_mcap(
                tmp / MCAP_NAME,
                frames=kept,
                task=task,
                instruction=instruction,
                success=success,
                fps=FPS,
                metadata={k: json.dumps(v) for k, v in info.items()},
                jpegs=jpegs,
            )
            (tmp / INFO_NAME).write_text(json.dumps({**info, "length": length}, sort_keys=True))
            commit_folder(tmp, out)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        return out

    return finish


def _check_video_lengths(root: Path, frames: int) -> None:
    """Every video of a one-episode dataset has ``frames`` frames (container metadata)."""
    import av

    for video in sorted(root.glob("videos/**/*.mp4")):
        with av.open(str(video)) as container:
            count = container.streams.video[0].frames
        if count != frames:
            raise RuntimeError(f"{video.name} of {root} has {count} frames, expected {frames}")


@contextlib.contextmanager
def quiet_datasets() -> Iterator[None]:
    """Silence the ``datasets`` library's per-episode progress bars, then restore the setting."""
    from datasets.utils import are_progress_bars_disabled, disable_progress_bars, enable_progress_bars

    was_disabled = are_progress_bars_disabled()
    disable_progress_bars()
    try:
        yield
    finally:
        if not was_disabled:
            enable_progress_bars()
