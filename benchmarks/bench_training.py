"""Training throughput per policy, and the share of step time spent waiting for data.

For each policy (ResNet-RNN, ResNet-T, ViT-T) at the ``paper`` and ``smoke`` sizes, on one
dataset: ``libero_bench``'s window loader (``TaskLoader``, the run's batch size and window)
feeds behaviour-cloning steps (loss, backward, gradient clipping, AdamW) on ``--device``.
Per step, the time blocked in the loader's ``next`` is *data wait*; the rest is compute.
The first ``--warmup`` steps are not counted. Medians of ``--reps`` runs of ``--steps``
steps; prints a Markdown table and, with ``--results``, replaces this benchmark's section
of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

POLICIES = ("resnet_rnn", "resnet_t", "vit_t")


def one_run(
    root: Path, policy_name: str, size: str, device: str, steps: int, warmup: int, workers: int
) -> tuple[float, float]:
    """(samples per second, share of time waiting for data) over ``steps`` training steps."""
    import numpy as np
    import torch

    from libero_bench.data.dataset import DemoDataset
    from libero_bench.data.windows import TaskLoader, WindowDataset
    from libero_bench.policies import make_policy, policy_config
    from libero_bench.train.presets import get_preset

    preset = get_preset(size)
    source = DemoDataset(root)
    config = policy_config(policy_name, size, image_size=source.image_size)
    policy = make_policy(policy_name, size, image_size=source.image_size).to(device)
    episodes = list(range(int(source.info["total_episodes"])))
    embs = np.zeros((1, config.task_emb_dim), dtype=np.float32)
    windows = WindowDataset(source, episodes, [0] * len(episodes), embs, window=config.window)
    loader = TaskLoader(windows, preset.batch_size, device, seed=0, workers=workers)
    optimiser = torch.optim.AdamW(policy.parameters(), lr=1e-4)
    policy.train()
    wait = compute = 0.0
    samples = 0
    done = 0
    while done < steps + warmup:
        it = iter(loader)
        while done < steps + warmup:
            t0 = time.perf_counter()
            try:
                batch = next(it)
            except StopIteration:
                break
            t1 = time.perf_counter()
            loss = policy.loss(batch)
            optimiser.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(policy.parameters(), 100.0)
            optimiser.step()
            if device.startswith("cuda"):
                torch.cuda.synchronize()
            t2 = time.perf_counter()
            if done >= warmup:
                wait += t1 - t0
                compute += t2 - t1
                samples += int(next(iter(batch.values())).shape[0])
            done += 1
    return samples / (wait + compute), wait / (wait + compute)


def measure(
    root: Path, device: str, steps: int, warmup: int, reps: int, workers: int, sizes: list[str]
) -> list[dict[str, Any]]:
    rows = []
    for size in sizes:
        for name in POLICIES:
            runs = [one_run(root, name, size, device, steps, warmup, workers) for _ in range(reps)]
            rows.append(
                {
                    "policy": name,
                    "size": size,
                    "samples_per_s": statistics.median(r[0] for r in runs),
                    "wait_share": statistics.median(r[1] for r in runs),
                }
            )
    return rows


def table(rows: list[dict[str, Any]], args: argparse.Namespace) -> str:
    lines = [
        f"Run: `python -m benchmarks.bench_training <dataset> --device {args.device} --steps {args.steps} "
        f"--reps {args.reps} --sizes {args.sizes}` (window loader with {args.workers} loader workers; paper batch 32, smoke batch 8; "
        f"window 10; medians of {args.reps} runs of {args.steps} steps after {args.warmup} warm-up steps).",
        "",
        "| policy | size | samples/s | data wait share | target |",
        "|---|---|---:|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['policy']} | {r['size']} | {r['samples_per_s']:.1f} | {r['wait_share']:.1%} | ≤ 5% wait |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a libero-data dataset folder")
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--warmup", type=int, default=2)
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--workers", type=int, default=0, help="DataLoader worker processes")
    parser.add_argument("--sizes", default="paper,smoke", help="policy sizes to measure (comma-separated)")
    parser.add_argument("--results", type=Path, help="RESULTS.md to update")
    args = parser.parse_args()
    import torch

    torch.set_num_threads(int(os.environ.get("OMP_NUM_THREADS", "1")))
    sizes = [x for x in args.sizes.split(",") if x]
    rows = measure(args.dataset, args.device, args.steps, args.warmup, args.reps, args.workers, sizes)
    text = table(rows, args)
    print(text)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(args.results, f"Training ({args.device}, {' and '.join(sizes)} sizes)", text)


if __name__ == "__main__":
    main()
