"""Evaluation throughput: rollouts per minute with 1 and 2 worker processes, worker memory.

``libero_bench.train.rounds.run_round`` on a run's open environment slots runs ``--rollouts`` rollouts of a smoke-size ResNet-T
policy (untrained: its rollouts run to ``--max-steps``, the worst case) on one task, both
cameras at ``--size``, each rollout written as a LeRobot shard, MCAP log and Rerun
recording like in a real run. Measured with 1 and with 2 worker processes (the pool is
started and warmed up with one round first, as a run's pool stays up between rounds); one
worker both as it runs by default (Mesa's llvmpipe renders on one thread per core, so it
already uses the second core for part of its rendering) and confined to one rendering
thread (one core), the baseline a second worker on a second core is compared with.
Peak resident memory (VmHWM) of every worker is read from /proc.

With ``--memory-rollouts N`` a single worker then runs N more rollouts and its resident
memory (VmRSS) is sampled after each: growth across them would be a leak.
Prints Markdown and, with ``--results``, replaces this benchmark's section of
``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("SVT_LOG", "1")

from benchmarks.results import growth_summary, status_mib


def rollout_jobs(task_ref: str, n: int, size: int, max_steps: int, work: Path, first: int = 0) -> list[Any]:
    import numpy as np

    from libero_bench.rollouts.jobs import EvalTask, make_job
    from libero_data.tasks import get_task

    task = get_task(task_ref)
    states = task.init_states()
    eval_task = EvalTask(
        name=task.name,
        language=task.language,
        position=0,
        env_ref=str(task.bddl_path),
        task_emb=np.zeros(384, dtype=np.float32),
        init_states=states,
    )
    return [
        make_job(
            eval_task,
            r,
            key=f"r{r:04d}",
            settle=10,
            max_steps=max_steps,
            image_size=size,
            sim_state_width=states.shape[1],
            shard_dir=work / "shards" / f"r{r:04d}",
            rrd_path=work / "rrd" / f"r{r:04d}.rrd",
            tags={"bench": True},
        )
        for r in range(first, first + n)
    ]


def _policy(size: int) -> Any:
    import torch

    from libero_bench.policies import make_policy

    torch.manual_seed(0)
    return make_policy("resnet_t", "smoke", image_size=size)


def rate(
    task_ref: str, workers: int, rollouts: int, size: int, max_steps: int, render_threads: int | None = None
) -> tuple[float, list[float]]:
    """(rollouts per minute, peak MiB of each worker); ``render_threads`` sets llvmpipe's
    thread count in the new workers (None: Mesa's default, one per core)."""
    from libero_bench.rollouts.loop import EnvironmentSlots
    from libero_bench.train.rounds import run_round
    from libero_data.runtime.jobs import JobPlacement

    work = Path(tempfile.mkdtemp(prefix="bench-eval-"))
    policy = _policy(size)
    saved = os.environ.pop("LP_NUM_THREADS", None)
    if render_threads is not None:
        os.environ["LP_NUM_THREADS"] = str(render_threads)  # read by each worker as it starts
    try:
        with EnvironmentSlots(JobPlacement("local", workers), work, workers) as slots:
            run_round(
                slots, policy, rollout_jobs(task_ref, workers, size, max_steps, work / "warm")
            )  # warm up
            start = time.perf_counter()
            run_round(
                slots,
                policy,
                rollout_jobs(task_ref, rollouts, size, max_steps, work / "timed", first=workers),
            )
            minutes = (time.perf_counter() - start) / 60
            pids = slots.worker_pids()
            peaks = [status_mib(pid, "VmHWM") for pid in pids]
        return rollouts / minutes, peaks
    finally:
        os.environ.pop("LP_NUM_THREADS", None)
        if saved is not None:
            os.environ["LP_NUM_THREADS"] = saved
        shutil.rmtree(work, ignore_errors=True)


def memory_trace(task_ref: str, rollouts: int, size: int, max_steps: int) -> list[float]:
    """Resident MiB of one worker after each of ``rollouts`` rollouts."""
    from libero_bench.rollouts.loop import EnvironmentSlots
    from libero_bench.train.rounds import run_round
    from libero_data.runtime.jobs import JobPlacement

    work = Path(tempfile.mkdtemp(prefix="bench-eval-mem-"))
    policy = _policy(size)
    trace = []
    try:
        with EnvironmentSlots(JobPlacement("local", 1), work, 1) as slots:
            for r in range(rollouts):
                run_round(slots, policy, rollout_jobs(task_ref, 1, size, max_steps, work / f"m{r}", first=r))
                (pid,) = slots.worker_pids()
                trace.append(status_mib(pid, "VmRSS"))
                shutil.rmtree(work / f"m{r}", ignore_errors=True)
        return trace
    finally:
        shutil.rmtree(work, ignore_errors=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="libero_object/0")
    parser.add_argument("--rollouts", type=int, default=8)
    parser.add_argument("--max-steps", type=int, default=40)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument(
        "--repeats",
        type=int,
        default=3,
        help="Runs of each configuration, taking turns; medians are reported.",
    )
    parser.add_argument("--memory-rollouts", type=int, default=0)
    parser.add_argument(
        "--memory-only",
        action="store_true",
        help="Only the memory trace (--memory-rollouts), into its own section of RESULTS.md.",
    )
    parser.add_argument("--results", type=Path, help="RESULTS.md to update")
    args = parser.parse_args()
    if args.memory_only:
        trace = memory_trace(args.task, args.memory_rollouts, args.size, args.max_steps)
        text = (
            f"Run: `python -m benchmarks.bench_eval --task {args.task} --max-steps {args.max_steps} --size "
            f"{args.size} --memory-rollouts {args.memory_rollouts} --memory-only` (one worker, smoke ResNet-T, "
            "each rollout stored as shard + MCAP + .rrd).\n\n"
            + "One worker: "
            + growth_summary(trace, "rollouts")
        )
        print(text)
        if args.results:
            from benchmarks.results import replace_section

            replace_section(args.results, "Evaluation memory", text)
        return
    # One worker rendering on one llvmpipe thread (one core), one worker with Mesa's default
    # of one thread per core (it already spreads its rendering over both cores), two workers.
    configs = {"1x1": (1, 1), "1": (1, None), "2": (2, None)}
    runs: dict[str, list[tuple[float, list[float]]]] = {name: [] for name in configs}
    for _ in range(args.repeats):  # taking turns, so load changes hit all alike
        for name, (workers, threads) in configs.items():
            runs[name].append(rate(args.task, workers, args.rollouts, args.size, args.max_steps, threads))
    med = {name: statistics.median(r for r, _ in v) for name, v in runs.items()}
    peak = {name: [max(p) for p in zip(*(peaks for _, peaks in v), strict=True)] for name, v in runs.items()}
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1

    def mib(name: str) -> str:
        return ", ".join(f"{p:.0f}" for p in peak[name])

    lines = [
        f"Run: `python -m benchmarks.bench_eval --task {args.task} --rollouts {args.rollouts} --max-steps "
        f"{args.max_steps} --size {args.size} --repeats {args.repeats}"
        + (f" --memory-rollouts {args.memory_rollouts}" if args.memory_rollouts else "")
        + "` (smoke ResNet-T, untrained, so every rollout runs to the step limit; two cameras; "
        f"each rollout stored as shard + MCAP + .rrd); medians of {args.repeats} runs per configuration, "
        f"taking turns; this machine has {cores} cores.",
        "",
        "| workers | llvmpipe threads per worker | rollouts/min | speed-up | peak MiB per worker | target |",
        "|---:|---:|---:|---:|---|---|",
        f"| 1 | 1 | {med['1x1']:.1f} | 1.00 | {mib('1x1')} | |",
        f"| 1 | {cores} (default) | {med['1']:.1f} | {med['1'] / med['1x1']:.2f}× | {mib('1')} | |",
        f"| 2 | {cores} (default) | {med['2']:.1f} | {med['2'] / med['1x1']:.2f}× one worker on one core; "
        f"{med['2'] / med['1']:.2f}× one worker as it runs by default | {mib('2')} | ≥ 1.8× |",
    ]
    if args.memory_rollouts:
        trace = memory_trace(args.task, args.memory_rollouts, args.size, args.max_steps)
        lines += ["", "One worker: " + growth_summary(trace, "rollouts")]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(args.results, "Evaluation", text)


if __name__ == "__main__":
    main()
