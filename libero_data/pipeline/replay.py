"""``libero-data replay``: a stored episode as a Rerun recording.

Frames come from the dataset itself (decoded by lerobot), so the recording shows exactly
what a policy would be trained on: both cameras, the 8-D state, the action and the task's
language, on a ``frame`` timeline (and ``time`` in seconds).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from libero_data.errors import InputError
from libero_data.record.features import ACTION, ACTION_NAMES, OBS_STATE, STATE_NAMES, camera_keys_of
from libero_data.record.rrd import rrd_file
from libero_data.runtime.files import read_json


def episode_to_rrd(root: str | Path, episode: int, out: str | Path) -> Path:
    """Write episode ``episode`` of the dataset at ``root`` to the ``.rrd`` file ``out``."""
    import rerun as rr
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from libero_data.pipeline.readable import readable_dataset

    root = Path(root)
    info = readable_dataset(root)
    total = int(info.get("total_episodes", 0))
    if not 0 <= episode < total:
        raise InputError(f"{root} has episodes 0..{total - 1}, not {episode}", field="episode")
    dataset = LeRobotDataset(_repo_id(root), root=root, episodes=[episode])
    out = Path(out)
    language = None
    fps = float(info["fps"])
    with rrd_file(out, "libero-data", f"{root.name}-episode-{episode}") as rec:
        for i in range(len(dataset)):
            item = dataset[i]
            t = int(item["frame_index"])
            rec.set_time("frame", sequence=t)
            rec.set_time("time", duration=t / fps)
            if language is None:
                language = str(item["task"])
                rec.log("language", rr.TextDocument(language), static=True)
                rec.log("log", rr.TextLog(f"episode {episode}: {language}"))
            for camera, key in camera_keys_of(info["features"]).items():
                path = f"cameras/{camera}"
                if key in item:
                    image = (item[key].permute(1, 2, 0).numpy() * 255).round().clip(0, 255).astype(np.uint8)
                    rec.log(path, rr.Image(image).compress(jpeg_quality=90))
            state = item[OBS_STATE].numpy()
            action = item[ACTION].numpy()
            for name, value in zip(STATE_NAMES, state, strict=True):
                rec.log(f"state/{name}", rr.Scalars(float(value)))
            for name, value in zip(ACTION_NAMES, action, strict=True):
                rec.log(f"action/{name}", rr.Scalars(float(value)))
    return out


def _repo_id(root: Path) -> str:
    meta = root / "meta" / "libero.json"
    if meta.is_file():
        return str((read_json(meta).get("request") or {}).get("repo_id") or f"local/{root.name}")
    return f"local/{root.name}"
