"""Evaluation with one batched policy against a policy copy per worker, LeRobot policies on CPU.

Two ways to roll a LeRobot policy out with N environments, on the same machine in one run:

- **per worker** (libero-bench eval before the batched path): N worker processes, each loading its
  own copy of the policy on one torch thread and acting one observation at a time
  (``select_action`` with batch 1), as the job runner's rollout jobs did;
- **batched** (:mod:`libero_bench.rollouts`): the policy loaded once, in the driver, acting for the N
  environments at once (one ``predict_action_chunk`` over every environment whose chunk ran out),
  the environments stepping in N worker processes (or one per core) that load no policy.

For an inference-heavy policy (Diffusion Policy at LeRobot's default size, 278 M parameters, with
10 DDIM denoising steps per chunk) and a light one (ACT at LeRobot's default size), with random
weights (a throughput and memory measurement: untrained, every rollout runs to the step limit),
both cameras at ``--size``, every rollout stored (shard, MCAP, Rerun). Each configuration runs in a
fresh Python process (its own peak memory): one warm-up round (workers start, environments and
policies load), then ``--rounds`` x N timed rollouts. Reported: rollouts per minute, the sum of the
resident memory of the driver and its workers at the end, and how many processes hold the policy.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as the command-line tools set it
os.environ.setdefault("SVT_LOG", "1")

KINDS = ("diffusion", "act")
#: (way, workers per environment: 1, or 0 for one worker per core)
WAYS = (("per-worker", 1), ("batched", 1), ("batched", 0))


def save_policy(kind: str, out: Path, size: int) -> Path:
    """A LeRobot policy of ``kind`` at LeRobot's default size (random weights) saved at ``out``."""
    import torch
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.factory import get_policy_class, make_policy_config, make_pre_post_processors

    cameras = ("observation.images.image", "observation.images.wrist_image")
    inputs = {name: PolicyFeature(type=FeatureType.VISUAL, shape=(3, size, size)) for name in cameras}
    inputs["observation.state"] = PolicyFeature(type=FeatureType.STATE, shape=(8,))
    outputs = {"action": PolicyFeature(type=FeatureType.ACTION, shape=(7,))}
    options: dict[str, Any] = {
        "device": "cpu",
        "input_features": inputs,
        "output_features": outputs,
        "pretrained_backbone_weights": None,
    }
    if kind == "diffusion":
        crop = int(size * 0.875)
        options.update(
            crop_shape=(crop, crop),
            horizon=16,
            n_action_steps=8,
            num_inference_steps=10,
            noise_scheduler_type="DDIM",
        )
    config = make_policy_config(kind, **options)
    torch.manual_seed(0)
    policy = get_policy_class(kind)(config)
    stats: dict[str, dict[str, Any]] = {
        name: {"mean": torch.full((3, 1, 1), 0.5), "std": torch.full((3, 1, 1), 0.25)} for name in cameras
    }
    stats["observation.state"] = {"mean": torch.zeros(8), "std": torch.ones(8)}
    stats["action"] = {"mean": torch.zeros(7), "std": torch.full((7,), 0.3)}
    for entry in stats.values():
        entry["min"], entry["max"] = entry["mean"] - 2 * entry["std"], entry["mean"] + 2 * entry["std"]
    pre, post = make_pre_post_processors(config, dataset_stats=stats)
    out.mkdir(parents=True, exist_ok=True)
    policy.save_pretrained(out)
    pre.save_pretrained(out)
    post.save_pretrained(out)
    return out


# -- per worker: every worker process its own policy copy, batch 1 --------------------------------
def per_worker_rollout(ctx: Any, job: Any) -> Any:
    """One rollout as the job runner's workers ran them: the worker's own policy copy, one torch
    thread, ``select_action`` on one observation at a time (a job function: module level)."""
    import numpy as np
    import torch

    from libero_bench.rollouts.episodes import EpisodeHost
    from libero_bench.rollouts.lerobot_actor import raw_batch

    assert ctx.shared is not None
    policy, pre, post, inputs = ctx.cache.get("policy", str(ctx.shared), lambda: _load(ctx.shared))
    host = EpisodeHost(ctx)
    observation: Any = host.start(0, job)
    policy.reset()
    while True:
        with torch.inference_mode():
            action = post(policy.select_action(pre(raw_batch(inputs, [observation], [job.language]))))
        observation, result = host.step(0, np.asarray(action.cpu().numpy()).reshape(-1)[:7])
        if result is not None:
            return result


def _load(folder: Path) -> tuple[Any, Any, Any, Any]:
    import torch
    from lerobot.policies.factory import get_policy_class, make_pre_post_processors

    from libero_bench.rollouts.lerobot_inputs import inputs_from_features, lerobot_config

    torch.set_num_threads(1)
    config = lerobot_config(folder)
    policy = get_policy_class(config.type).from_pretrained(str(folder), config=config).eval()
    pre, post = make_pre_post_processors(policy_cfg=config, pretrained_path=str(folder))
    return policy, pre, post, inputs_from_features(config.input_features)


def measure(
    way: str, folder: Path, envs: int, workers: int, rounds: int, task: str, size: int, max_steps: int
) -> dict[str, Any]:
    """One configuration, in this process: rollouts per minute, memory, policy copies, successes."""
    from benchmarks.results import status_mib

    work = Path(tempfile.mkdtemp(prefix="bench-batched-"))
    from benchmarks.bench_eval import rollout_jobs

    warm = rollout_jobs(task, envs, size, max_steps, work / "warm")
    timed = rollout_jobs(task, rounds * envs, size, max_steps, work / "timed", first=envs)
    if way == "per-worker":
        from libero_data.runtime.jobs import JobPlacement, JobRunner

        with JobRunner(JobPlacement("local", envs), work) as runner:
            list(runner.run(per_worker_rollout, warm, shared=folder))
            start = time.perf_counter()
            results = [r for _, r in runner.run(per_worker_rollout, timed, shared=folder)]
            seconds = time.perf_counter() - start
            pids = runner.worker_pids()
            rss = [status_mib(pid, "VmRSS") for pid in [os.getpid(), *pids]]
        copies = max(len(pids), 1)  # one worker: this process holds the copy
    else:
        from libero_bench.rollouts.lerobot_actor import LeRobotActor
        from libero_bench.rollouts.loop import RolloutResources
        from libero_data.runtime.jobs import JobPlacement

        actor = LeRobotActor(folder, "cpu")
        with RolloutResources(JobPlacement("local", workers), batch_size=envs).open(work) as environments:
            list(environments.run(actor, warm))
            start = time.perf_counter()
            results = [r for _, r in environments.run(actor, timed)]
            seconds = time.perf_counter() - start
            pids = environments.worker_pids()
            rss = [status_mib(pid, "VmRSS") for pid in [os.getpid(), *pids]]
        copies = 1
    return {
        "way": way,
        "envs": envs,
        "workers": len(pids),
        "rollouts": len(results),
        "per_minute": len(results) / (seconds / 60),
        "successes": sum(r.success for r in results),
        "rss_mib": sum(rss),
        "rss_each": rss,
        "copies": copies,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="libero_object/0")
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--max-steps", type=int, default=40)
    parser.add_argument("--rounds", type=int, default=2, help="Timed rollouts per environment.")
    parser.add_argument("--envs", default="2,4")
    parser.add_argument("--kinds", default=",".join(KINDS))
    parser.add_argument("--results", type=Path, help="RESULTS.md to update")
    parser.add_argument(
        "--one", nargs=4, metavar=("WAY", "FOLDER", "ENVS", "WORKERS"), help=argparse.SUPPRESS
    )
    args = parser.parse_args()
    if args.one:
        way, folder, envs, workers = args.one
        result = measure(
            way, Path(folder), int(envs), int(workers), args.rounds, args.task, args.size, args.max_steps
        )
        print(json.dumps(result))
        return
    rows = []
    cores = len(os.sched_getaffinity(0))
    with tempfile.TemporaryDirectory() as tmp:
        for kind in args.kinds.split(","):
            folder = save_policy(kind, Path(tmp) / kind, args.size)
            for envs in (int(e) for e in args.envs.split(",")):
                for way, per_env in WAYS:
                    if not per_env and envs <= cores:
                        continue  # one worker per environment already
                    workers = envs if per_env else cores
                    command = [
                        sys.executable,
                        "-m",
                        "benchmarks.bench_batched_eval",
                        "--one",
                        way,
                        str(folder),
                    ]
                    command += [str(envs), str(workers), "--task", args.task, "--size", str(args.size)]
                    command += ["--max-steps", str(args.max_steps), "--rounds", str(args.rounds)]
                    out = subprocess.run(command, capture_output=True, text=True, check=False)
                    if out.returncode != 0:
                        raise SystemExit(out.stderr[-3000:])
                    row = {"kind": kind, **json.loads(out.stdout.strip().splitlines()[-1])}
                    print(json.dumps(row), flush=True)
                    rows.append(row)
    text = table(rows, args)
    print(text)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(args.results, "Evaluation: one batched policy", text)


def table(rows: list[dict[str, Any]], args: argparse.Namespace) -> str:
    cores = len(os.sched_getaffinity(0))
    lines = [
        f"Run: `python -m benchmarks.bench_batched_eval --task {args.task} --size {args.size} --max-steps "
        f"{args.max_steps} --rounds {args.rounds} --envs {args.envs}` on {cores} cores: LeRobot policies at "
        "LeRobot's default sizes with random weights (Diffusion Policy 278 M parameters, 10 DDIM steps per "
        "8-action chunk; ACT 52 M, 100-action chunks), so every rollout runs to the step limit; two cameras, "
        "every rollout stored. Memory: resident MiB of the driver and its workers together after the timed "
        "rollouts. Success is 0 for both ways (untrained policies): the equality of outcomes is shown by the "
        "tests instead (tests/bench/test_rollout_actors.py: the batched actions equal LeRobot's own loop per "
        "environment; test_policy_server.py: served equals local).",
        "",
        "| policy | environments | way | worker processes | rollouts/min | speed-up | resident MiB (all processes) | policy copies |",
        "|---|---:|---|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        base = next(
            r
            for r in rows
            if r["kind"] == row["kind"] and r["envs"] == row["envs"] and r["way"] == "per-worker"
        )
        speed = row["per_minute"] / base["per_minute"]
        lines.append(
            f"| {row['kind']} | {row['envs']} | {row['way']} | {row['workers']} | {row['per_minute']:.2f} | {speed:.2f}× | "
            f"{row['rss_mib']:.0f} | {row['copies']} |"
        )
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
