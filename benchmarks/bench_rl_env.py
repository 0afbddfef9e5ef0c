"""The RL environment's speed and memory against RLinf's ``LiberoEnv``, same machine, same task.

Each environment runs ``--calls`` chunk calls of ``--chunk`` actions (no motion, the gripper
open: the RLinf adapter's) on ``--task`` at 256 px with full rendering (LIBERO's pixels), episodes
cut at ``--max-steps`` and reset automatically, as an RL rollout runs; no policy (the environments
alone). RLinf's protocol beside ours: it draws every step of a chunk (ours the chunk's last),
settles 15 steps after a reset (ours 10) and runs its evaluations past success. Measured at 1, 2
and 4 environments and chunks of 5 and 10:

- ours: :class:`libero_bench.rl.vector.LiberoVectorEnv` (one worker process per core, at most one
  per environment; the first reset, which builds the scenes, is not timed);
- RLinf's ``LiberoEnv`` (``benchmarks/peers/rlinf_env_run.py`` in the peers' own environment,
  made by ``benchmarks/peers/make_envs.sh``: one process per environment; its first reset is not
  timed either). Left out without ``--rlinf``.

Environment steps per second (all environments together), and resident memory per environment
(the environment processes' VmRSS summed, over the number of environments; the driver left out on
both sides: it holds the policy).

    python -m benchmarks.bench_rl_env --rlinf .cache/peers/rlinf/bin/python --results
    python -m benchmarks.bench_rl_env --memory-episodes 2000   # memory over 2,000 resets, ours
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]


def still(envs: int, chunk: int) -> Any:
    """The actions of one call, the adapter's for RLinf: no motion, the gripper open."""
    import numpy as np

    actions = np.zeros((envs, chunk, 7))
    actions[:, :, 6] = -1.0
    return actions


def measure_ours(args: argparse.Namespace, envs: int, chunk: int) -> dict[str, Any]:
    """Ours, in a fresh process (as RLinf's adapter runs): nothing left from the measurement before."""
    command = [
        sys.executable,
        "-m",
        "benchmarks.bench_rl_env",
        *("--ours", f"{envs},{chunk}", "--task", args.task, "--calls", str(args.calls)),
        *("--max-steps", str(args.max_steps), "--image-size", str(args.image_size)),
    ]
    done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def ours_here(args: argparse.Namespace, envs: int, chunk: int) -> dict[str, Any]:
    from benchmarks.results import status_mib
    from libero_bench.rl.vector import LiberoVectorEnv

    env = LiberoVectorEnv(
        args.task, envs, chunk=chunk, image_size=args.image_size, max_episode_steps=args.max_steps
    )
    try:
        env.reset(seed=0)
        steps = episodes = 0
        started = time.perf_counter()
        actions = still(envs, chunk)
        for _call in range(args.calls):
            _obs, _reward, terminated, truncated, info = env.step(actions)
            steps += int(info["steps"].sum())
            episodes += int((terminated | truncated).sum())
        seconds = time.perf_counter() - started
        rss = sum(status_mib(pid, "VmRSS") for pid in env.worker_pids())
    finally:
        env.close()
    return {"steps": steps, "episodes": episodes, "seconds": seconds, "mib_per_env": rss / envs}


def memory_trace(args: argparse.Namespace) -> str:
    """Resident memory of two workers (one environment each) over ``--memory-episodes`` one-step
    episodes (each a reset, a step and an observation drawn), sampled every 20 episodes."""
    from benchmarks.results import growth_summary, status_mib
    from libero_bench.rl.vector import LiberoVectorEnv

    env = LiberoVectorEnv(args.task, 2, image_size=args.image_size, max_episode_steps=1, settle=0)
    trace = []
    try:
        env.reset(seed=0)
        for call in range(args.memory_episodes // 2):
            env.step(still(2, 1))
            if call % 10 == 9:
                trace.append(sum(status_mib(pid, "VmRSS") for pid in env.worker_pids()) / 2)
    finally:
        env.close()
    return growth_summary(trace, f"samples of {args.memory_episodes} one-step episodes (per worker)")


def measure_rlinf(args: argparse.Namespace, envs: int, chunk: int) -> dict[str, Any]:
    suite, _, task = args.task.rpartition("/")
    command = [
        args.rlinf,
        str(ROOT / "benchmarks" / "peers" / "rlinf_env_run.py"),
        *("--suite", suite, "--task", task, "--num-envs", str(envs), "--chunk-size", str(chunk)),
        *(
            "--chunk-steps",
            str(args.calls),
            "--max-steps",
            str(args.max_steps),
            "--size",
            str(args.image_size),
        ),
    ]
    done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    result = json.loads(done.stdout.strip().splitlines()[-1])
    per_env = result["rss_mib_per_env_process"]
    return {
        "steps": result["env_steps"],
        "episodes": result["episodes_finished"],
        "seconds": result["loop_s"],
        "mib_per_env": sum(per_env) / len(per_env),
        "version": f"rlinf {result['version']}, rlinf-libero {result['rlinf_libero_version']}",
    }


def table(rows: list[dict[str, Any]], args: argparse.Namespace) -> str:
    lines = [
        f"`{args.task}`, {args.image_size} px full rendering, {args.calls} chunk calls per environment, "
        f"episodes cut at {args.max_steps} steps and reset automatically; no policy (the environments alone).",
        "",
        "| environments | chunk | RLinf steps/s | ours steps/s | ours ÷ RLinf | RLinf rollouts/min "
        "| ours rollouts/min | RLinf MiB/env | ours MiB/env |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    per_min = 60 / args.max_steps  # rollouts per minute of an environment step rate, at this length
    for row in rows:
        ours, peer = row["ours"], row.get("rlinf")
        ours_rate = ours["steps"] / ours["seconds"]
        if peer:
            peer_rate = peer["steps"] / peer["seconds"]
            cells = [f"{peer_rate:.1f}", f"{ours_rate:.1f}", f"**{ours_rate / peer_rate:.2f}×**"]
            cells += [f"{peer_rate * per_min:.2f}", f"{ours_rate * per_min:.2f}"]
            memory = [f"{peer['mib_per_env']:.0f}", f"{ours['mib_per_env']:.0f}"]
        else:
            cells = ["", f"{ours_rate:.1f}", "", "", f"{ours_rate * per_min:.2f}"]
            memory = ["", f"{ours['mib_per_env']:.0f}"]
        lines.append(f"| {row['envs']} | {row['chunk']} | " + " | ".join(cells + memory) + " |")
    lines += [
        "",
        f"Rollouts per minute: episodes of {args.max_steps} steps at the measured step rate (steps/s × 60 / "
        f"{args.max_steps}; resets are inside the timed calls on both sides).",
        "",
        "Memory: the environment processes' resident MiB over their environments. At one environment "
        "ours runs in the measuring process (the RL environment's `workers=1` is this process), so its "
        "figure is that whole process, imports included; RLinf's is its environment process alone "
        "(its driver, ~750 MiB, left out).",
    ]
    peers = sorted({row["rlinf"]["version"] for row in rows if row.get("rlinf")})
    if peers:
        lines += ["", f"Peer: {', '.join(peers)} (its own environment, `benchmarks/peers/make_envs.sh`)."]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--task", default="libero_object/0")
    parser.add_argument("--envs", default="1,2,4", help="Numbers of environments, comma-separated.")
    parser.add_argument("--chunks", default="5,10", help="Chunk sizes, comma-separated.")
    parser.add_argument("--calls", type=int, default=60, help="Chunk calls per measurement.")
    parser.add_argument("--max-steps", type=int, default=280, help="Episode length (libero_object's limit).")
    parser.add_argument("--image-size", type=int, default=256)
    parser.add_argument("--rlinf", default="", help="The peers' RLinf environment's python.")
    parser.add_argument(
        "--results", action="store_true", help="Replace this benchmark's section of RESULTS.md."
    )
    parser.add_argument(
        "--memory-episodes", type=int, default=0, help="Instead: memory over this many one-step episodes."
    )
    parser.add_argument("--ours", default="", help=argparse.SUPPRESS)  # ENVS,CHUNK: one measurement here
    args = parser.parse_args()
    if args.ours:
        envs, chunk = (int(n) for n in args.ours.split(","))
        print(json.dumps(ours_here(args, envs, chunk)))
        return
    if args.memory_episodes:
        print(memory_trace(args))
        return
    rows = []
    for envs in (int(n) for n in args.envs.split(",")):
        for chunk in (int(c) for c in args.chunks.split(",")):
            row: dict[str, Any] = {"envs": envs, "chunk": chunk}
            if args.rlinf:
                row["rlinf"] = measure_rlinf(args, envs, chunk)
            row["ours"] = measure_ours(args, envs, chunk)
            print(json.dumps(row), flush=True)
            rows.append(row)
    body = table(rows, args)
    print(body)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(ROOT / "benchmarks" / "RESULTS.md", "RL environment: against RLinf's LiberoEnv", body)


if __name__ == "__main__":
    main()
