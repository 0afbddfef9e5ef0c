"""Does a trained policy open the gripper where its own demonstrations do? Each episode's last release
(its last opening action after a closing one), fed to the run's policy with the demonstration's
own window of frames before it: the share of episodes whose predicted gripper action opens, at
the release and at frames around it (issue 74: today's libero_spatial/7 policies stop over the plate
with the bowl held).

    python -m benchmarks.pace_release RUN DATA [--every 4] [--out FILE.json]

RUN is a ``libero-bench run`` folder (its final checkpoint), DATA the dataset it learned from.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

#: Frames around the release asked about (0: the first opening action).
OFFSETS = (-6, -3, -1, 0, 1, 2, 5)


def release_frame(gripper: Any) -> int | None:
    """The last frame whose gripper action opens (< 0) right after one that closes (> 0): the
    release that reaches the goal (an earlier one, a drawer's handle let go, is followed by more
    of the episode)."""
    for t in range(len(gripper) - 1, 0, -1):
        if gripper[t - 1] > 0 and gripper[t] < 0:
            return t
    return None


def measure(run: Path, data: Path, every: int = 4) -> dict[str, Any]:
    import numpy as np
    import torch

    from libero_bench.data.dataset import DemoDataset
    from libero_bench.data.windows import WindowDataset, batch_to_device
    from libero_bench.runs.saved_policy import load_run_policy

    torch.set_num_threads(1)
    loaded = load_run_policy(run)
    source = DemoDataset(data)
    window = int(loaded.config["preset"]["window"])
    languages = [t.language for t in source.tasks]
    embeddings = np.asarray(loaded.embed(languages), dtype=np.float32)
    pairs = sorted((e, i) for i, task in enumerate(source.tasks) for e in task.episodes)[::every]
    episodes = [e for e, _ in pairs]
    windows = WindowDataset(source, episodes, [i for _, i in pairs], embeddings, window)
    starts = {pair: i for i, pair in enumerate(windows.index)}
    opened: dict[int, list[bool]] = {offset: [] for offset in OFFSETS}
    for slot in range(len(episodes)):
        gripper = windows.frames(slot).actions[:, -1]
        release = release_frame(gripper)
        if release is None:
            continue
        for offset in OFFSETS:
            i = starts.get((slot, release + offset - window + 1))
            if i is None or release + offset >= len(gripper):
                continue
            batch = {key: value.unsqueeze(0) for key, value in windows[i].items()}
            opened[offset].append(float(loaded.policy.act(batch_to_device(batch, "cpu"))[0, -1]) < 0)
    return {
        "run": run.name,  # names, not this machine's paths: the file is committed
        "data": data.name,
        "episodes": len(episodes),
        "opens": {
            str(k): {"open": sum(v), "of": len(v), "demonstration": "open" if k >= 0 else "closed"}
            for k, v in opened.items()
        },
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("data", type=Path)
    parser.add_argument("--every", type=int, default=4, help="every Nth episode (default 4: 25 of 100)")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    result = measure(args.run, args.data, args.every)
    for offset, row in result["opens"].items():
        print(
            f"release {int(offset):+d} (demonstration {row['demonstration']}): "
            f"policy opens in {row['open']}/{row['of']}"
        )
    if args.out:
        args.out.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
