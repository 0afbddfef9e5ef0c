"""Rerun recordings (``.rrd``) of evaluation rollouts and saliency maps.

A rollout recording has a ``step`` timeline (and ``time`` in seconds at 20 Hz) with
``cameras/agentview`` and ``cameras/eye_in_hand`` (JPEG), ``state/<name>`` (8),
``joints/<name>`` (7), ``action/<name>`` (7) and ``success`` (0/1 after each step) as
scalars; the instruction is the static ``language`` document and the rollout's tags the
static ``tags`` document; a final text log says whether the goal was reached.
Read them back with ``rerun.recording.load_recording`` (``rerun.dataframe`` before 0.28).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.record.mcap_log import episode_jpegs, once_per_image
from libero_data.record.rrd import rrd_file

FPS = 20
STATE_NAMES = ["eef_x", "eef_y", "eef_z", "eef_ax", "eef_ay", "eef_az", "gripper_left", "gripper_right"]
ACTION_NAMES = ["dx", "dy", "dz", "drx", "dry", "drz", "gripper"]
JOINT_NAMES = [f"joint_{i}" for i in range(1, 8)]
CAMERAS = {"agentview": "cameras/agentview", "eye_in_hand": "cameras/eye_in_hand"}


def write_rollout_rrd(
    path: str | Path,
    *,
    frames: Sequence[Mapping[str, Any]],
    success: Sequence[bool],
    language: str,
    tags: Mapping[str, Any],
    recording_id: str,
    jpegs: Callable[[np.ndarray], bytes] | None = None,
) -> Path:
    """Write one rollout (env observations with an ``action`` each) to ``path`` atomically; its
    images as JPEG (quality 90), from ``jpegs`` where another log of the rollout made them
    (:func:`~libero_data.record.mcap_log.episode_jpegs`)."""
    import rerun as rr

    if len(frames) != len(success):
        raise ValueError(f"{len(frames)} frames but {len(success)} success flags")
    out = Path(path)
    with rrd_file(out, "libero-bench", recording_id) as rec:
        rec.log("language", rr.TextDocument(language), static=True)
        rec.log("tags", rr.TextDocument(json.dumps(dict(tags), sort_keys=True, default=str)), static=True)
        encoded = jpegs or episode_jpegs()
        jpeg = once_per_image(lambda image: rr.EncodedImage(contents=encoded(image), media_type="image/jpeg"))
        for step, obs in enumerate(frames):
            rec.set_time("step", sequence=step)
            rec.set_time("time", duration=step / FPS)
            for camera, entity in CAMERAS.items():
                if camera in obs:
                    rec.log(entity, jpeg(obs[camera]))
        # The scalars go as columns, one call per series, not one call per value and step.
        steps = np.arange(len(frames))
        times = [rr.TimeColumn("step", sequence=steps), rr.TimeColumn("time", duration=steps / FPS)]
        _scalars(rec, times, "state", STATE_NAMES, [obs.get("state") for obs in frames])
        _scalars(rec, times, "joints", JOINT_NAMES, [obs.get("joint_pos") for obs in frames])
        _scalars(rec, times, "action", ACTION_NAMES, [obs.get("action") for obs in frames])
        if frames:
            rec.send_columns(
                "success", indexes=times, columns=rr.Scalars.columns(scalars=np.asarray(success, float))
            )
            rec.set_time("step", sequence=len(frames) - 1)
            rec.set_time("time", duration=(len(frames) - 1) / FPS)
            outcome = "success: the goal holds" if any(success) else "failure: the goal was not reached"
            rec.log("log", rr.TextLog(f"{language}: {outcome} after {len(frames)} steps"))
    return out


def _scalars(rec: Any, times: list[Any], prefix: str, names: Sequence[str], values: Sequence[Any]) -> None:
    """One series per name over every step (none where the frames lack it)."""
    import rerun as rr

    if not values or any(v is None for v in values):
        return
    table = np.stack([np.asarray(v, dtype=np.float64).reshape(-1) for v in values])
    for name, column in zip(names, table.T, strict=False):
        rec.send_columns(f"{prefix}/{name}", indexes=times, columns=rr.Scalars.columns(scalars=column))


def write_saliency_rrd(
    path: str | Path,
    *,
    images: Sequence[np.ndarray],
    maps: Sequence[np.ndarray],
    overlays: Sequence[np.ndarray],
    frame_indices: Sequence[int],
    language: str,
    recording_id: str,
) -> Path:
    """Saliency maps on a ``frame`` timeline: ``agentview`` (the input image, HxWx3 uint8),
    ``saliency`` (the map, HxW float in [0, 1]) and ``overlay`` (HxWx3 uint8)."""
    import rerun as rr

    out = Path(path)
    with rrd_file(out, "libero-bench-saliency", recording_id) as rec:
        rec.log("language", rr.TextDocument(language), static=True)
        for index, image, sal, over in zip(frame_indices, images, maps, overlays, strict=True):
            rec.set_time("frame", sequence=int(index))
            rec.log("agentview", rr.Image(np.asarray(image, dtype=np.uint8)))
            rec.log("saliency", rr.Image(np.asarray(sal, dtype=np.float32)))
            rec.log("overlay", rr.Image(np.asarray(over, dtype=np.uint8)))
    return out
