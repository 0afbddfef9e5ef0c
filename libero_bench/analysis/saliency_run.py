"""Saliency maps of a run's checkpoint on frames of a task's demonstrations or rollouts
(``libero-bench saliency``): PNG overlays and a Rerun recording.

The checkpoint kept after a task (by default the task itself) is loaded with its
algorithm's evaluation view of that task (PackNet's per-task masks), and
:func:`libero_bench.analysis.saliency.saliency_map` scores the agentview encoder on the chosen
frames. Each PNG shows the frame and the overlay side by side.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.runs.folder import RunFolder, find_task
from libero_bench.runs.saved_policy import kept_checkpoint, policy_from_checkpoint
from libero_data.errors import InputError, RunError

logger = logging.getLogger(__name__)


def _episode_for(folder: RunFolder, config: dict, chosen: dict, source: str, rollout: int) -> tuple[Any, int]:
    """(dataset, episode index) of the task's first demonstration or its ``rollout``-th rollout."""
    from libero_bench.data.dataset import DemoDataset
    from libero_bench.runs.training_data import resolve

    if source == "demo":
        data = DemoDataset(resolve(folder.root, config["data"]))
        episodes = chosen.get("episodes") or list(data.task(chosen["name"]).episodes)
        return data, int(episodes[0])
    if source == "rollout":
        data = DemoDataset(folder.rollouts)
        mine = [i for i, row in enumerate(data.episode_meta) if row.get("task_name") == chosen["name"]]
        if not mine:
            raise RunError(f"{folder.rollouts} has no rollouts of task {chosen['name']}")
        if rollout >= len(mine):
            raise InputError(
                f"task {chosen['name']} has rollouts 0..{len(mine) - 1}, not {rollout}", field="rollout"
            )
        return data, mine[rollout]
    raise InputError(f"the source must be demo or rollout, got {source!r}", field="source")


def saliency_for_run(
    run: str | Path,
    *,
    task: str,
    frames: list[int] | None = None,
    source: str = "demo",
    rollout: int = 0,
    after: str | None = None,
    out: str | Path | None = None,
    stride: int = 5,
) -> list[Path]:
    """Write ``frame_NNNNN.png`` overlays and ``saliency.rrd`` into ``out``; returns the paths."""
    from PIL import Image

    from libero_bench.analysis.saliency import overlay, saliency_map
    from libero_bench.data.language import encode_tasks
    from libero_bench.rollouts.rerun_log import write_saliency_rrd

    folder = RunFolder(Path(run))
    config = folder.read_config()
    chosen = find_task(config, task)
    position = int(chosen["position"])
    kept = find_task(config, after) if after is not None else chosen
    policy, algo = policy_from_checkpoint(
        config, kept_checkpoint(folder, config, int(kept["position"])), position
    )
    languages = [t["language"] for t in config["tasks"]]
    emb = encode_tasks(languages, config["preset"]["language_encoder"])[position]
    data, episode = _episode_for(folder, config, chosen, source, rollout)
    decoded = data.load_episode(episode, int(policy.config.image_size))
    length = len(decoded)
    if frames is None:
        frames = sorted({round(float(x)) for x in np.linspace(0, length - 1, min(4, length))})
    bad = [f for f in frames if not 0 <= f < length]
    if bad:
        raise InputError(f"the episode has frames 0..{length - 1}, not {bad[0]}", field="frames")

    target = Path(out) if out is not None else folder.root / "saliency" / chosen["name"]
    target.mkdir(parents=True, exist_ok=True)
    images, maps, overlays, written = [], [], [], []
    for f in frames:
        image = decoded.agentview[f].float().div(255.0)
        sal = saliency_map(policy, image, emb, stride=stride)
        rgb = decoded.agentview[f].permute(1, 2, 0).numpy()
        blend = overlay(rgb, sal)
        path = target / f"frame_{f:05d}.png"
        side = Image.fromarray(np.concatenate([rgb, blend], axis=1))
        scale = max(1, 256 // rgb.shape[0])  # small frames are enlarged (nearest) to be seen
        side.resize((side.width * scale, side.height * scale), Image.Resampling.NEAREST).save(path)
        images.append(rgb)
        maps.append(sal)
        overlays.append(blend)
        written.append(path)
    algo.set_eval_task(None)
    rrd = write_saliency_rrd(
        target / "saliency.rrd",
        images=images,
        maps=maps,
        overlays=overlays,
        frame_indices=frames,
        language=str(chosen["language"]),
        recording_id=f"{folder.root.name}-{chosen['name']}-saliency",
    )
    logger.info("saliency of %s (%s episode %d): %d frames", chosen["name"], source, episode, len(frames))
    return [*written, rrd]
