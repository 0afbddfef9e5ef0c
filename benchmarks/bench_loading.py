"""Training-sample throughput: libero_bench's window loader against LeRobotDataset.

Both deliver the same samples — windows of ``--window`` consecutive frames with both cameras,
joint and gripper states and actions — in a ``torch.utils.data.DataLoader`` (batch
``--batch``, ``--workers`` processes) over one dataset:

- **ours**: ``libero_bench.data.windows.WindowDataset`` (each episode's videos decoded once, then
  slices of the cache): the warm rate, and the rate of a first epoch (decoding every
  episode once, then every window once);
- **LeRobot**: ``LeRobotDataset`` with ``delta_timestamps`` (decodes the frames of every
  sample from the videos).

Medians of ``--reps`` runs of ``--batches`` batches; prints a Markdown table and, with
``--results``, replaces this benchmark's section of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")


def _rate(loader, batches: int, batch: int) -> float:
    start = time.perf_counter()
    n = 0
    for i, _ in enumerate(loader):
        n += batch
        if i + 1 >= batches:
            break
    return n / (time.perf_counter() - start)


def ours(root: Path, window: int, batch: int, batches: int, workers: int) -> tuple[float, float, int]:
    import numpy as np
    import torch

    from libero_bench.data.dataset import DemoDataset
    from libero_bench.data.windows import WindowDataset

    source = DemoDataset(root)
    episodes = [e for t in source.tasks for e in t.episodes]
    data = WindowDataset(source, episodes, [0] * len(episodes), np.zeros((1, 8), np.float32), window)
    start = time.perf_counter()
    data.preload()
    decode = time.perf_counter() - start
    loader: torch.utils.data.DataLoader[Any] = torch.utils.data.DataLoader(
        data,  # type: ignore[arg-type]
        batch_size=batch,
        shuffle=True,
        num_workers=workers,
    )
    warm = _rate(loader, batches, batch)
    # One epoch from a cold start: decode every episode once, then every window once.
    epoch = len(data) / (decode + len(data) / warm)
    return warm, epoch, data.cached_bytes


def lerobot(root: Path, window: int, batch: int, batches: int, workers: int) -> float:
    import json

    import torch
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    info = json.loads((root / "meta" / "info.json").read_text())
    fps = info["fps"]
    offsets = [i / fps for i in range(window)]
    from libero_data.record.features import StoredColumns

    stored = StoredColumns.of(info["features"])
    keys = [
        "observation.images.image",
        "observation.images.wrist_image",
        stored.joints,
        stored.gripper,
        "action",
    ]
    ds = LeRobotDataset("bench/loading", root=root, delta_timestamps={k: offsets for k in keys})
    loader = torch.utils.data.DataLoader(ds, batch_size=batch, shuffle=True, num_workers=workers)
    return _rate(loader, batches, batch)


def measure(root: Path, window: int, batch: int, batches: int, workers: int, reps: int) -> dict[str, float]:
    import numpy as np  # noqa: F401  (loaded before timing)

    ours_rates, lerobot_rates, cold = [], [], []
    cached = 0
    for _ in range(reps):
        rate, epoch, cached = ours(root, window, batch, batches, workers)
        cold.append(epoch)
        ours_rates.append(rate)
        lerobot_rates.append(lerobot(root, window, batch, batches, workers))
    return {
        "ours_cold": statistics.median(cold),
        "ours_warm": statistics.median(ours_rates),
        "lerobot": statistics.median(lerobot_rates),
        "cached_bytes": float(cached),
    }


def main() -> None:
    import json

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path, help="a libero-data dataset folder")
    parser.add_argument("--window", type=int, default=10)
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--batches", type=int, default=20)
    parser.add_argument("--workers", type=int, default=0)
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--results", type=Path)
    args = parser.parse_args()
    r = measure(args.root, args.window, args.batch, args.batches, args.workers, args.reps)
    info = json.loads((args.root / "meta" / "info.json").read_text())
    frames = info["total_frames"]
    text = "\n".join(
        [
            f"Dataset: {info['total_episodes']} episodes, {frames} frames; windows of {args.window}, "
            f"batch {args.batch}, {args.batches} batches, {args.workers} loader workers, medians of {args.reps}.",
            "",
            "| loader | samples/s | ratio | target |",
            "|---|---:|---:|---|",
            f"| LeRobotDataset + delta_timestamps | {r['lerobot']:.0f} | 1.00 | |",
            f"| libero_bench WindowDataset, first epoch (decoding included) | {r['ours_cold']:.0f} | {r['ours_cold'] / r['lerobot']:.1f}× | ≥ 5× |",
            f"| libero_bench WindowDataset, warm cache | {r['ours_warm']:.0f} | {r['ours_warm'] / r['lerobot']:.1f}× | ≥ 5× |",
            "",
            f"Cache: {r['cached_bytes'] / frames * 1000 / 2**20:.0f} MiB per 1,000 frames (both cameras, uint8).",
        ]
    )
    print(text)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(args.results, "Loading", text)


if __name__ == "__main__":
    main()
