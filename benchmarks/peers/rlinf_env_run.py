"""Step RLinf 0.3.0's LIBERO environment (``LiberoEnv``) on one task with a stand-in policy.

Run it with the peer's own interpreter (built by ``benchmarks/peers/make_envs.sh``)::

    .cache/peers/rlinf/bin/python benchmarks/peers/rlinf_env_run.py \\
        --suite libero_object --task 0 --num-envs 2 --chunk-steps 3 --chunk-size 10 --latency 0.07

What runs: ``rlinf.envs.libero.libero_env.LiberoEnv(cfg, num_envs, seed_offset=0,
total_num_processes=1, worker_info=None)`` with an OmegaConf cfg shaped like RLinf's LIBERO
eval config (``is_eval``, ``auto_reset`` and ``ignore_terminations`` true, ``seed`` 0,
``reset_gripper_open`` true, 256 px cameras, ``task_id_filter=[task]``), then ``reset()``
and ``--chunk-steps`` calls of ``chunk_step(actions[num_envs, chunk_size, 7])`` with
zero-motion actions (gripper ``--gripper``, -1 = open), sleeping ``--latency`` seconds
before each call as a stand-in for one batched policy call over all environments.
``--mode train`` uses the training settings instead (no ``is_eval``, terminations end
episodes).

Prints ONE JSON line at the end: wall seconds of the whole command, of the imports, of
``LiberoEnv(...)`` (which only spawns the env processes), of the first ``reset()`` (which
waits for them to import LIBERO and build their envs, then resets and settles) and of the
chunk loop; env steps (num_envs x chunk steps x chunk size, and with the settle steps) and
env steps per second of the loop; episodes finished (auto-resets); VmRSS (after reset and
at the end) and VmHWM of the main process and of every environment process, in MiB;
RLinf's and rlinf-libero's versions.

RLinf's protocol, as read in its installed source (paths under ``rlinf/envs/``):

- One spawned process per environment (``libero/venv.py`` 169-190, ``multiprocessing``
  "spawn"), stepped in lockstep: each step sends every worker its action, then waits for
  all (``venv/venv.py`` 802-809). Observations are not encoded: images come back as
  arrays, flipped ``[::-1, ::-1]`` (``libero/utils.py`` 90, 108) and stacked into tensors.
- ``chunk_step`` executes every action of the chunk (``libero/libero_env.py`` 749-764);
  the policy is called once per chunk for all environments.
- Reset (``libero/libero_env.py`` 649-711): ``env.seed(cfg.seed * len(env_idx))`` at *every*
  reset, which seeds *all* workers with ``seed + i`` (``venv/venv.py`` 858-865), then
  ``reset`` and ``set_init_state``, then 15 settle steps of zero actions (gripper -1 only
  when ``reset_gripper_open``), not counted as episode steps. Outside eval mode every
  reset also rebuilds the worker's ``OffScreenRenderEnv`` (``task_changed or not
  self.is_eval``, line 658).
- Evaluation runs past success: RLinf's LIBERO eval configs (``examples/embodiment/config/
  env/eval/libero_*.yaml`` in its repository; the wheel ships no configs) set
  ``ignore_terminations: true`` and ``max_episode_steps: 512``, so ``step`` zeroes the terminations (lines
  733-735) and an episode ends only at ``max_episode_steps``; success is kept as
  ``success_once``.
- Init states (eval mode): the task's trials are dealt round-robin to the
  ``total_num_processes`` ``LiberoEnv`` instances (``libero/utils.py`` 200); within one
  instance each environment takes the next trial of that pool at every reset (here
  trials 0, 1, ... of the task).
"""

from __future__ import annotations

import time

_T0 = time.monotonic()

import argparse  # noqa: E402
import ctypes.util  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402
from importlib import metadata  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

SETTLE_STEPS = 15  # LiberoEnv.reset's zero-action steps (libero/libero_env.py 701)


def proc_status_mib(pid: int) -> dict[str, float]:
    """VmRSS and VmHWM of ``pid`` in MiB from /proc (empty once the process is gone)."""
    out: dict[str, float] = {}
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith(("VmRSS:", "VmHWM:")):
                key, value = line.split(":", 1)
                out[key] = int(value.split()[0]) / 1024
    except (FileNotFoundError, ProcessLookupError):
        pass
    return out


def default_gl() -> str:
    """EGL where its library is present, else OSMesa (the project's own order)."""
    return "egl" if ctypes.util.find_library("EGL") else "osmesa"


def make_cfg(args: argparse.Namespace) -> Any:
    """An env cfg with every key ``LiberoEnv`` reads (values from RLinf's LIBERO configs)."""
    from omegaconf import OmegaConf

    evaluating = args.mode == "eval"
    return OmegaConf.create(
        {
            "task_suite_name": args.suite,
            "task_id_filter": [args.task],
            "seed": args.seed,
            "group_size": 1,
            "is_eval": evaluating,
            "auto_reset": True,
            "ignore_terminations": evaluating,
            "max_episode_steps": args.max_steps,
            "use_fixed_reset_state_ids": True,
            "use_ordered_reset_state_ids": False,
            "reset_gripper_open": True,
            "use_rel_reward": True,
            "reward_coef": 5.0,
            "video_cfg": {"save_video": False, "info_on_video": False, "video_base_dir": "/tmp"},
            "init_params": {"camera_heights": args.size, "camera_widths": args.size},
        }
    )


def run(args: argparse.Namespace) -> dict[str, Any]:
    os.environ.setdefault("LIBERO_CONFIG_PATH", str(Path(sys.prefix) / "libero-config"))
    os.environ["MUJOCO_GL"] = args.gl
    os.environ["PYOPENGL_PLATFORM"] = args.gl  # inherited by the spawned env processes

    import numpy as np
    import torch
    from rlinf.envs.libero.libero_env import LiberoEnv

    t_import = time.monotonic()
    env = LiberoEnv(
        make_cfg(args), num_envs=args.num_envs, seed_offset=0, total_num_processes=1, worker_info=None
    )
    t_built = time.monotonic()
    env.reset()
    t_reset = time.monotonic()
    workers = {f"env{i}": w.process.pid for i, w in enumerate(env.env.workers)}
    pids = {"main": os.getpid()} | workers
    rss_after_reset = {name: proc_status_mib(pid).get("VmRSS", 0.0) for name, pid in pids.items()}

    actions = np.zeros((args.num_envs, args.chunk_size, 7))
    actions[..., -1] = args.gripper
    episodes = 0
    successes = 0
    for _ in range(args.chunk_steps):
        if args.latency > 0:
            time.sleep(args.latency)
        _obs, _rewards, terminations, truncations, infos = env.chunk_step(actions)
        done = torch.logical_or(terminations, truncations).any(dim=1)
        episodes += int(done.sum())
        final = infos[-1].get("final_info") if done.any() else None
        if final is not None:
            successes += int(torch.as_tensor(final["episode"]["success_once"])[done].sum())
    t_loop = time.monotonic()
    status = {name: proc_status_mib(pid) for name, pid in pids.items()}
    env.env.close()

    steps = args.num_envs * args.chunk_steps * args.chunk_size
    loop_s = t_loop - t_reset
    return {
        "peer": "rlinf",
        "version": metadata.version("rlinf"),
        "rlinf_libero_version": metadata.version("rlinf-libero"),
        "suite": args.suite,
        "task": args.task,
        "task_name": env.task_descriptions[0],
        "mode": args.mode,
        "num_envs": args.num_envs,
        "chunk_steps": args.chunk_steps,
        "chunk_size": args.chunk_size,
        "max_steps": args.max_steps,
        "latency_s": args.latency,
        "gl": args.gl,
        "wall_s": round(time.monotonic() - _T0, 3),
        "import_s": round(t_import - _T0, 3),
        "construct_s": round(t_built - t_import, 3),
        "first_reset_s": round(t_reset - t_built, 3),
        "loop_s": round(loop_s, 3),
        "env_steps": steps,
        # 15 settle steps per reset: the first one and one after each finished episode.
        "env_steps_with_settle": steps + SETTLE_STEPS * (args.num_envs + episodes),
        "env_steps_per_s": round(steps / loop_s, 3) if loop_s > 0 else None,
        "episodes_finished": episodes,
        "successes": successes,
        "rss_after_reset_mib": {k: round(v, 1) for k, v in rss_after_reset.items()},
        "rss_end_mib": {k: round(v.get("VmRSS", 0.0), 1) for k, v in status.items()},
        "hwm_mib": {k: round(v.get("VmHWM", 0.0), 1) for k, v in status.items()},
        "rss_mib_per_env_process": [round(status[k].get("VmRSS", 0.0), 1) for k in workers],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--suite", default="libero_object")
    parser.add_argument("--task", type=int, default=0)
    parser.add_argument("--num-envs", type=int, default=1, help="environment processes (lockstep)")
    parser.add_argument("--chunk-steps", type=int, default=3, help="chunk_step calls after the reset")
    parser.add_argument("--chunk-size", type=int, default=10, help="actions per chunk_step call")
    parser.add_argument("--max-steps", type=int, default=512, help="max_episode_steps (RLinf's LIBERO: 512)")
    parser.add_argument("--latency", type=float, default=0.0, help="seconds slept before each chunk_step")
    parser.add_argument(
        "--gripper", type=float, default=-1.0, help="gripper value of the actions (-1 = open)"
    )
    parser.add_argument("--seed", type=int, default=0, help="cfg.seed (RLinf's LIBERO configs: 0)")
    parser.add_argument("--size", type=int, default=256, help="camera height and width")
    parser.add_argument("--mode", choices=("eval", "train"), default="eval")
    parser.add_argument("--gl", choices=("egl", "osmesa"), default=default_gl())
    args = parser.parse_args()
    if min(args.num_envs, args.chunk_steps, args.chunk_size, args.max_steps) < 1:
        parser.error("--num-envs, --chunk-steps, --chunk-size and --max-steps must be >= 1")
    print(json.dumps(run(args)), flush=True)


if __name__ == "__main__":
    main()
