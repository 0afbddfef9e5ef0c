"""Run vla-eval 0.8.0's LIBERO benchmark on one task against a stand-in model server.

Run it with the peer's own interpreter (built by ``benchmarks/peers/make_envs.sh``)::

    .cache/peers/vla-eval/bin/python benchmarks/peers/vla_eval_run.py \\
        --suite libero_object --task 0 --episodes 2 --max-steps 30 --shards 2 --latency 0.07

What runs: ``vla-eval run -c CONFIG --no-docker --no-save`` once per shard (with
``--shard-id i --num-shards S`` when S > 1), each a separate process holding one
``OffScreenRenderEnv`` in-process (256 px cameras), all talking to one stand-in model
server: our own websocket server (``serve`` below, started as a subprocess) that speaks
vla-eval's protocol, sleeps ``--latency`` seconds whenever it has to "infer", answers
chunks of ``--chunk-size`` zero-motion actions (gripper ``--gripper``, -1 = open) one per
observation, and never succeeds; it asks for the agentview image only, or with
``--wrist-and-state`` also for the wrist image and the 8-D state (what vla-eval's pi0
server asks for in its HELLO reply). With ``--server-mode serial`` inference calls of all
shards queue behind one lock (like vla-eval's ``PredictModelServer`` with
``max_batch_size=1``); ``concurrent`` (default) lets them overlap (an ideally batched
server). The generated config (``vla-eval.yaml``) and shard logs are left in ``--workdir``.

Prints ONE JSON line at the end: wall seconds of the whole command, of the shard processes
(start to exit) and of the loop (the server's first observation to its last EPISODE_END,
so it excludes start-up and the first reset but includes later episodes' resets); episodes
finished; env steps (policy steps as vla-eval counts them, and with the settle steps) and
env steps per second of the loop; peak VmRSS / VmHWM of every shard process and of the
server, in MiB; vla-eval's version.

vla-eval's protocol, as read in its installed source (paths under ``vla_eval/``):

- One observation per env step, one action back (``runners/sync_runner.py`` 55-64;
  ``connection.py`` ``act``): the harness sends an OBSERVATION (agentview image flipped
  ``[::-1, ::-1]``, PNG-encoded by ``protocol/numpy_codec.py`` 27/48-49, plus the
  instruction) at *every* step and waits for one 7-D action. Chunking lives in the model
  server: ``PredictModelServer`` (``model_servers/predict.py`` 292-296) serves buffered
  actions and calls ``predict()`` only when its chunk buffer is empty, so every action of
  a chunk is executed (their pi0 server's default ``chunk_size`` is 10,
  ``model_servers/pi0.py`` 53), unlike openpi's LIBERO client, which replans after 5 of 10.
- The gripper is binarised before ``env.step``: ``-1 if a[-1] < 0 else +1``
  (``benchmarks/libero/benchmark.py`` 230-235), so a gripper value of 0 closes it.
- Reset (``benchmarks/libero/benchmark.py`` 188-219): one env per task and process,
  ``env.seed(7)`` once at creation, then per episode ``env.reset()``,
  ``set_init_state(init_states[episode_idx])`` and 10 wait steps of ``[0]*6 + [-1]``
  (not counted in the episode's steps); 256 px cameras; limits 220/280/300/520/400 unless
  ``max_steps`` is set; success = ``done``, which ends the episode (``check_done``).
- Shards are independent processes; without a recording DB (``--no-save``) each takes a
  fixed, seed-shuffled slice of the (task, episode) items (``orchestrator.py`` 66-73, 353).
"""

from __future__ import annotations

import time

_T0 = time.monotonic()

import argparse  # noqa: E402
import ctypes.util  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import re  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import threading  # noqa: E402
from importlib import metadata  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

LIBERO_BENCHMARK = "vla_eval.benchmarks.libero.benchmark:LIBEROBenchmark"
EPISODE_LINE = re.compile(r"\[(\d+)/(\d+)\] (.*) ep(\d+): (SUCCESS|FAIL) \(steps=(\d+)\)")
ERRORED_LINE = re.compile(r"^\S+: [\d.]+%\s+\(\S* ?(\d+) episodes errored\)$", re.MULTILINE)
SETTLE_STEPS = 10  # vla-eval's num_steps_wait default, set explicitly in the config


# --- the stand-in model server ---------------------------------------------------------


def _ndarray(values: list[float]) -> dict[str, Any]:
    """A float32 vector in vla-eval's msgpack ndarray form (``protocol/numpy_codec.py``)."""
    import numpy as np

    arr = np.asarray(values, dtype=np.float32)
    return {"__ndarray__": True, "data": arr.tobytes(), "dtype": arr.dtype.str, "shape": list(arr.shape)}


def serve(
    port: int,
    latency: float,
    chunk_size: int,
    gripper: float,
    mode: str,
    wrist_and_state: bool,
    stats_path: Path,
) -> None:
    """Serve vla-eval's websocket protocol until SIGTERM; then write call counts to ``stats_path``."""
    import asyncio
    import signal

    import msgpack
    from websockets.asyncio.server import serve as ws_serve

    action = _ndarray([0.0] * 6 + [gripper])
    stats: dict[str, Any] = {"connections": 0, "observations": 0, "inference_calls": 0, "episodes_ended": 0}
    # CLOCK_MONOTONIC is system-wide, so the adapter can compare these with its own clock.
    stats["first_observation_t"] = None
    stats["last_episode_end_t"] = None

    def pack(kind: str, payload: dict[str, Any], seq: int) -> bytes:
        return msgpack.packb(
            {"type": kind, "payload": payload, "seq": seq, "timestamp": time.time()}, use_bin_type=True
        )

    async def main() -> None:
        lock = asyncio.Lock()
        stop = asyncio.Event()
        asyncio.get_running_loop().add_signal_handler(signal.SIGTERM, stop.set)

        async def handle(ws: Any) -> None:
            stats["connections"] += 1
            buffered = 0  # actions left in this session's chunk
            async for raw in ws:
                # Images arrive PNG-encoded; a stand-in has no use for them, so they stay bytes.
                msg = msgpack.unpackb(raw, raw=False)
                kind, seq = msg["type"], msg["seq"]
                if kind == "hello":
                    hello = {"harness_version": "stand-in", "protocol_version": 1, "model_server": "StandIn"}
                    if wrist_and_state:  # what vla-eval's pi0 server asks for (model_servers/pi0.py 87-93)
                        hello["observation_params"] = {"send_wrist_image": True, "send_state": True}
                    await ws.send(pack("hello", {**hello, "capabilities": {}}, seq))
                elif kind == "episode_start":
                    buffered = 0
                elif kind == "observation":
                    if stats["first_observation_t"] is None:
                        stats["first_observation_t"] = time.monotonic()
                    stats["observations"] += 1
                    if buffered == 0:
                        stats["inference_calls"] += 1
                        if mode == "serial":
                            async with lock:
                                await asyncio.sleep(latency)
                        else:
                            await asyncio.sleep(latency)
                        buffered = chunk_size
                    buffered -= 1
                    await ws.send(pack("action", {"actions": action}, seq))
                elif kind == "episode_end":
                    stats["episodes_ended"] += 1
                    stats["last_episode_end_t"] = time.monotonic()

        async with ws_serve(
            handle, "127.0.0.1", port, compression=None, max_size=None, ping_interval=None
        ) as server:
            print(f"PORT {server.sockets[0].getsockname()[1]}", flush=True)
            await stop.wait()
        stats_path.write_text(json.dumps(stats))

    asyncio.run(main())


# --- process accounting ----------------------------------------------------------------


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


class MemorySampler:
    """Samples VmRSS / VmHWM of some processes every ``period`` seconds; keeps the peaks."""

    def __init__(self, pids: dict[str, int], period: float = 0.25) -> None:
        self.pids = pids
        self.period = period
        self.peaks: dict[str, dict[str, float]] = {name: {} for name in pids}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _sample(self) -> None:
        for name, pid in self.pids.items():
            for key, mib in proc_status_mib(pid).items():
                self.peaks[name][key] = max(self.peaks[name].get(key, 0.0), mib)

    def _run(self) -> None:
        while not self._stop.wait(self.period):
            self._sample()

    def __enter__(self) -> MemorySampler:
        self._sample()
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


# --- the run ---------------------------------------------------------------------------


def default_gl() -> str:
    """EGL where its library is present, else OSMesa (the project's own order)."""
    return "egl" if ctypes.util.find_library("EGL") else "osmesa"


def peer_environment(gl: str) -> dict[str, str]:
    """Environment for the peer's processes: its own LIBERO path file and the GL backend."""
    env = dict(os.environ)
    env.setdefault("LIBERO_CONFIG_PATH", str(Path(sys.prefix) / "libero-config"))
    env["MUJOCO_GL"] = gl
    env["PYOPENGL_PLATFORM"] = gl
    return env


def task_name(suite: str, task: int, env: dict[str, str]) -> str:
    """The task's instruction, which vla-eval's ``tasks:`` filter matches (a short subprocess)."""
    code = (
        "import sys\nfrom libero.libero import benchmark\n"
        "print(benchmark.get_benchmark_dict()[sys.argv[1]]().get_task(int(sys.argv[2])).language)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, suite, str(task)], env=env, check=True, capture_output=True, text=True
    )
    return out.stdout.strip().splitlines()[-1]


def write_config(path: Path, args: argparse.Namespace, port: int, name: str) -> None:
    """vla-eval's run config (``vla_eval/config.py``: server, output_dir, render, benchmarks)."""
    import yaml

    config = {
        "server": {"url": f"ws://127.0.0.1:{port}", "timeout": 60.0},
        "output_dir": str(path.parent / "results"),
        # gpu = leave MUJOCO_GL as we set it; cpu = vla-eval sets OSMesa itself.
        "render": "cpu" if args.gl == "osmesa" else "gpu",
        "benchmarks": [
            {
                "benchmark": LIBERO_BENCHMARK,
                "subname": args.suite,
                "mode": "sync",
                "episodes_per_task": args.episodes,
                "max_steps": args.max_steps,
                "tasks": [name],
                "params": {"suite": args.suite, "seed": 7, "num_steps_wait": SETTLE_STEPS},
            }
        ],
    }
    path.write_text(yaml.safe_dump(config, sort_keys=False))


def run(args: argparse.Namespace) -> dict[str, Any]:
    workdir = Path(args.workdir or tempfile.mkdtemp(prefix="vla-eval-run-")).resolve()
    workdir.mkdir(parents=True, exist_ok=True)
    env = peer_environment(args.gl)
    name = task_name(args.suite, args.task, env)
    stats_path = workdir / "server-stats.json"
    server_cmd = [
        sys.executable, __file__, "serve", "--port", "0", "--latency", str(args.latency),
        "--chunk-size", str(args.chunk_size), "--gripper", str(args.gripper),
        "--server-mode", args.server_mode, "--stats", str(stats_path),
    ] + (["--wrist-and-state"] if args.wrist_and_state else [])  # fmt: skip
    server = subprocess.Popen(server_cmd, stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert server.stdout is not None
        line = server.stdout.readline()
        if not line.startswith("PORT "):
            raise RuntimeError(f"stand-in server did not start (got {line!r})")
        config_path = workdir / "vla-eval.yaml"
        write_config(config_path, args, int(line.split()[1]), name)

        vla_eval = str(Path(sys.executable).parent / "vla-eval")
        t_start = time.monotonic()
        shards: list[subprocess.Popen[bytes]] = []
        logs = []
        for shard in range(args.shards):
            cmd = [vla_eval, "run", "-c", str(config_path), "--no-docker", "--no-save"]
            if args.shards > 1:
                cmd += ["--shard-id", str(shard), "--num-shards", str(args.shards)]
            log = (workdir / f"shard{shard}.log").open("wb")
            logs.append(log)
            shards.append(subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=workdir))
        pids = {f"shard{i}": p.pid for i, p in enumerate(shards)} | {"server": server.pid}
        with MemorySampler(pids) as sampler:
            codes = [p.wait() for p in shards]
        shards_wall = time.monotonic() - t_start
        for log in logs:
            log.close()
    finally:
        server.terminate()
        server.wait(timeout=30)

    episodes, steps, successes, errored = 0, 0, 0, 0
    for shard in range(args.shards):
        text = (workdir / f"shard{shard}.log").read_text(errors="replace")
        for match in EPISODE_LINE.finditer(text):
            episodes += 1
            steps += int(match.group(6))
            successes += match.group(5) == "SUCCESS"
        # vla-eval isolates failing episodes and exits 0; its summary line counts them.
        errored += sum(int(m.group(1)) for m in ERRORED_LINE.finditer(text))
    shard_peaks = [sampler.peaks[f"shard{i}"] for i in range(args.shards)]
    stats = json.loads(stats_path.read_text()) if stats_path.exists() else {}
    first, last = stats.pop("first_observation_t", None), stats.pop("last_episode_end_t", None)
    loop_s = last - first if first is not None and last is not None else None
    return {
        "peer": "vla-eval",
        "version": metadata.version("vla-eval"),
        "suite": args.suite,
        "task": args.task,
        "task_name": name,
        "shards": args.shards,
        "episodes_requested": args.episodes,
        "max_steps": args.max_steps,
        "chunk_size": args.chunk_size,
        "latency_s": args.latency,
        "server_mode": args.server_mode,
        "wrist_and_state": args.wrist_and_state,
        "gl": args.gl,
        "wall_s": round(time.monotonic() - _T0, 3),
        "shards_wall_s": round(shards_wall, 3),
        "episodes_finished": episodes,
        "successes": successes,
        "episodes_errored": errored,
        "env_steps": steps,
        "env_steps_with_settle": steps + SETTLE_STEPS * episodes,
        "loop_s": round(loop_s, 3) if loop_s is not None else None,
        "env_steps_per_s": round(steps / loop_s, 3) if loop_s else None,
        "exit_codes": codes,
        "rss_peak_mib_per_shard": [round(p.get("VmRSS", 0.0), 1) for p in shard_peaks],
        "hwm_mib_per_shard": [round(p.get("VmHWM", 0.0), 1) for p in shard_peaks],
        "server_rss_peak_mib": round(sampler.peaks["server"].get("VmRSS", 0.0), 1),
        "server": stats,
        "workdir": str(workdir),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command")
    srv = sub.add_parser("serve", help="run only the stand-in model server (used internally)")
    for p in (parser, srv):
        p.add_argument("--latency", type=float, default=0.07, help="seconds slept per inference call")
        p.add_argument("--chunk-size", type=int, default=10, help="actions per inference call")
        p.add_argument("--gripper", type=float, default=-1.0, help="gripper value of the actions (-1 = open)")
        p.add_argument("--server-mode", choices=("concurrent", "serial"), default="concurrent")
        p.add_argument(
            "--wrist-and-state",
            action="store_true",
            help="ask for the wrist image and the 8-D state too, as vla-eval's pi0 server does",
        )
    srv.add_argument("--port", type=int, default=0)
    srv.add_argument("--stats", type=Path, required=True)
    parser.add_argument("--suite", default="libero_object")
    parser.add_argument("--task", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=1, help="episodes of the task, over all shards")
    parser.add_argument(
        "--max-steps", type=int, default=280, help="policy steps per episode (after settling)"
    )
    parser.add_argument("--shards", type=int, default=1, help="vla-eval processes (--shard-id/--num-shards)")
    parser.add_argument("--gl", choices=("egl", "osmesa"), default=default_gl())
    parser.add_argument("--workdir", help="where the config and shard logs go (default: a new temp dir)")
    args = parser.parse_args()
    if args.command == "serve":
        serve(
            args.port,
            args.latency,
            args.chunk_size,
            args.gripper,
            args.server_mode,
            args.wrist_and_state,
            args.stats,
        )
        return
    if args.episodes < 1 or args.shards < 1 or args.max_steps < 1 or args.chunk_size < 1:
        parser.error("--episodes, --shards, --max-steps and --chunk-size must be >= 1")
    print(json.dumps(run(args)), flush=True)


if __name__ == "__main__":
    main()
