"""LIBERO evaluation harnesses side by side, one machine, one task, one stand-in policy.

Every harness runs ``--episodes`` episodes of ``--task`` (256 px, full rendering: LIBERO's
pixels) of ``--max-steps`` steps after its waiting steps, against a stand-in policy that takes
``--latency`` seconds per forward pass at any batch size and answers chunks of ``--chunk``
actions that never succeed. Each is timed as a user runs it: the wall time of its whole
command, start-up included. The peers run in their own environments
(``benchmarks/peers/make_envs.sh``: from PyPI under ``.cache/peers``), each under its own
protocol:

- openpi's LIBERO client loop (``benchmarks/openpi_loop.py``, LIBERO's ``OffScreenRenderEnv``,
  one episode after another): 10 waiting steps, executes 5 actions of each chunk, draws every step;
- vla-eval 0.8.0 ``--no-docker`` (``benchmarks/peers/vla_eval_run.py``), 1 and 2 shards (one
  environment per process): 10 waiting steps, sends every step's observation (PNG-encoded),
  executes all actions of a chunk (buffered by its model server), binarises the gripper;
- RLinf 0.3.0's ``LiberoEnv`` (``benchmarks/peers/rlinf_env_run.py``), 1 and 2 environments (one
  process each, in lockstep): ``chunk_step`` executes all actions of a chunk and draws every
  step, settles 15 steps after a reset, reseeds every reset, runs past success (its evaluations
  set ``ignore_terminations``);
- ``libero-bench eval --protocol standard --server`` with 1 and 2 workers (openpi's requests
  exactly: 10 waits, 5 of each chunk, draws only what the policy reads, every rollout stored), and
  with ``--render-quality fast`` (not the standard's pixels).

Rollouts per minute, and each against the fastest peer at the same number of processes. The
machine's limit beside: the CPU time of every step as the standard protocol takes it (LIBERO's own
``env.step``) and of the two 256 px frames of each observation its policy reads, per core,
measured in the same run.

    bash benchmarks/peers/make_envs.sh
    python -m benchmarks.bench_peers --results
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmarks.bench_standard_eval import _eval, _free_port, _timed, stand_in_arguments

ROOT = Path(__file__).resolve().parents[1]
PEERS = ROOT / ".cache" / "peers"
#: Where each row's harness comes from (RESULTS names it).
OURS = "libero-bench"


@dataclass
class Row:
    label: str
    harness: str
    processes: int
    protocol: str
    seconds: float = float("nan")
    episodes: int = 0
    version: str = ""
    phases: dict[str, float] | None = None  # ours: where the time went (results.json), summed


def _peer_python(name: str) -> str:
    python = PEERS / name / "bin" / "python"
    if not python.exists():
        raise SystemExit(f"{python} is missing: run bash benchmarks/peers/make_envs.sh first")
    return str(python)


def _run_json(command: list[str]) -> tuple[float, dict[str, Any]]:
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    return seconds, json.loads(done.stdout.strip().splitlines()[-1])


def run_vla_eval(args: argparse.Namespace, shards: int) -> Row:
    suite, _, task = args.task.rpartition("/")
    seconds, result = _run_json(
        [
            _peer_python("vla-eval"),
            str(ROOT / "benchmarks" / "peers" / "vla_eval_run.py"),
            *("--suite", suite, "--task", task, "--episodes", str(args.episodes)),
            *("--max-steps", str(args.max_steps), "--shards", str(shards)),
            *("--chunk-size", str(args.chunk), "--latency", str(args.latency), "--wrist-and-state"),
        ]
    )
    protocol = "10 waits; every step sent (PNG); all actions of a chunk; gripper binarised"
    row = Row(f"vla-eval --no-docker, {shards} shard{'s' * (shards > 1)}", "vla-eval", shards, protocol)
    row.seconds, row.episodes, row.version = seconds, int(result["episodes_finished"]), result["version"]
    return row


def run_rlinf(args: argparse.Namespace, envs: int) -> Row:
    suite, _, task = args.task.rpartition("/")
    per_episode = math.ceil(args.max_steps / args.chunk)
    calls = math.ceil(args.episodes / envs) * per_episode
    seconds, result = _run_json(
        [
            _peer_python("rlinf"),
            str(ROOT / "benchmarks" / "peers" / "rlinf_env_run.py"),
            *("--suite", suite, "--task", task, "--num-envs", str(envs)),
            *("--chunk-steps", str(calls), "--chunk-size", str(args.chunk)),
            *("--max-steps", str(args.max_steps), "--latency", str(args.latency)),
        ]
    )
    protocol = "15 settle steps; all actions of a chunk, every step drawn; past success"
    row = Row(f"RLinf LiberoEnv, {envs} environment{'s' * (envs > 1)}", "RLinf", envs, protocol)
    row.seconds, row.episodes = seconds, int(result["episodes_finished"])
    row.version = f"rlinf {result['version']}, rlinf-libero {result['rlinf_libero_version']}"
    return row


def run_openpi(args: argparse.Namespace, url: str) -> Row:
    seconds = _timed(
        [
            sys.executable,
            "-m",
            "benchmarks.bench_standard_eval",
            *("--openpi-loop", url, "--task", args.task),
            *("--episodes", str(args.episodes), "--max-steps", str(args.max_steps)),
        ]
    )
    protocol = "10 waits; 5 actions of each chunk; every step drawn"
    return Row(
        "openpi's loop (sequential)",
        "openpi",
        1,
        protocol,
        seconds,
        args.episodes,
        "openpi-client 0.1.2 wire",
    )


def run_ours(args: argparse.Namespace, url: str, work: Path, workers: int, quality: str) -> Row:
    from libero_data.runtime.versions import versions

    out = work / f"ours-{workers}-{quality}"
    seconds = _timed(_eval(url, args, out, workers, quality, args.episodes))
    results = json.loads((out / "results.json").read_text())
    episodes = len(results["rollouts"])
    phases: dict[str, float] = {}
    for session in results.get("sessions", []):
        for name, value in session.get("phases", {}).items():
            phases[name] = phases.get(name, 0.0) + float(value)
    fast = ", fast (not the standard's pixels)" if quality == "fast" else ""
    label = f"libero-bench eval --protocol standard, {workers} worker{'s' * (workers > 1)}{fast}"
    protocol = "openpi's requests exactly; only frames the policy reads drawn; every rollout stored"
    version = f"libero-data {versions()['libero-data']}"
    return Row(label, OURS, workers, protocol, seconds, episodes, version, phases)


#: The phases of our rows that the table names (results.json's, summed over workers' rollouts).
PHASES = {"step_s": "steps", "store_s": "storing", "build_s": "builds", "reset_s": "resets"}


def machine_limit(args: argparse.Namespace) -> dict[str, float]:
    """CPU ms per control step as the standard protocol steps (LIBERO's own ``env.step`` through
    robosuite, :class:`~libero_data.sim.libero_loop.LiberoLoop`, images off) and per 256 px frame
    (one camera; llvmpipe's threads included) on this machine, and the standard protocol's least
    CPU seconds per episode from them."""
    code = (
        "import json, time, numpy as np\n"
        "from libero_data.sim import EnvConfig, LiberoEnv\n"
        "from libero_data.sim.libero_loop import LiberoLoop\n"
        "from libero_data.tasks import get_task\n"
        f"task = get_task({args.task!r})\n"
        "env = LiberoEnv(task, EnvConfig(image_size=256))\n"
        "loop = LiberoLoop(env)\n"
        "loop.reset(task.init_states()[0], 0)\n"
        "a = np.zeros(7); a[6] = -1\n"
        "t = time.process_time()\n"
        "for _ in range(200): loop.step(a, render=False)\n"
        "step = (time.process_time() - t) / 200\n"
        "t = time.process_time()\n"
        "for _ in range(20):\n"
        "    env.render('agentview'); env.render('eye_in_hand')\n"
        "frame = (time.process_time() - t) / 40\n"
        "print(json.dumps({'step_ms': step * 1e3, 'frame_ms': frame * 1e3}))\n"
    )
    _seconds, costs = _run_json([sys.executable, "-c", code])
    observations = math.ceil(args.max_steps / 5) + 1  # one per chunk of 5, and the first
    least = (args.max_steps + 10) * costs["step_ms"] + observations * 2 * costs["frame_ms"]
    return {**costs, "episode_s": least / 1e3}


def table(rows: list[Row], limit: dict[str, float], args: argparse.Namespace) -> str:
    peers = [r for r in rows if r.harness != OURS]
    lines = [
        f"Run: `python -m benchmarks.bench_peers --episodes {args.episodes} --max-steps {args.max_steps} --results` "
        f"({args.task}, 256 px full rendering unless said; a stand-in policy of {args.latency * 1000:.0f} ms per "
        f"forward pass at any batch size answering chunks of {args.chunk} that never succeed; {args.episodes} "
        "episodes per harness; wall time of the whole command, start-up included).",
        "",
        "| harness | its protocol | processes | episodes | seconds | rollouts/min | against the fastest peer at as many processes |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        rate = row.episodes / row.seconds * 60
        same = [p.episodes / p.seconds * 60 for p in peers if p.processes == row.processes]
        against = f"**{rate / max(same):.2f}×**" if row.harness == OURS and same else ""
        lines.append(
            f"| {row.label} | {row.protocol} | {row.processes} | {row.episodes} | {row.seconds:.0f} | {rate:.2f} | {against} |"
        )
    per_core = 60 / limit["episode_s"]
    lines += [
        "",
        f"The machine's limit under the standard protocol: {limit['step_ms']:.1f} CPU-ms per step (LIBERO's own "
        f"`env.step`, which the protocol keeps to the last bit), {limit['frame_ms']:.0f} CPU-ms per 256 px frame, "
        f"so at least {limit['episode_s']:.1f} CPU-s per episode ({args.max_steps + 10} steps, "
        f"{math.ceil(args.max_steps / 5) + 1} observations of two frames): {per_core:.2f} rollouts/min per core, "
        "the policy's time aside.",
    ]
    for row in rows:
        if row.phases:
            went = ", ".join(f"{label} {row.phases[k]:.0f}" for k, label in PHASES.items() if k in row.phases)
            lines.append(f"- {row.label}: seconds summed over its rollouts: {went}.")
    lines += [
        "",
        "Versions: " + "; ".join(sorted({f"{r.harness}: {r.version}" for r in rows if r.version})) + ".",
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    stand_in_arguments(parser)
    parser.add_argument(
        "--only", default="", help="Comma-separated harnesses to run (openpi, vla-eval, RLinf, ours)."
    )
    parser.add_argument(
        "--results", action="store_true", help="Replace this benchmark's section of RESULTS.md."
    )
    args = parser.parse_args()
    wanted = {w.strip().lower() for w in args.only.split(",") if w.strip()}

    def picked(name: str) -> bool:
        return not wanted or name.lower() in wanted

    port = _free_port()
    url = f"ws://127.0.0.1:{port}"
    stand_in = [sys.executable, "-m", "benchmarks.bench_standard_eval", "--serve", str(port)]
    server = subprocess.Popen([*stand_in, "--latency", str(args.latency), "--chunk", str(args.chunk)])
    rows: list[Row] = []
    try:
        time.sleep(8)
        with tempfile.TemporaryDirectory(prefix="bench-peers-") as tmp:
            work = Path(tmp)
            if picked("ours"):  # fast rendering's simplified meshes, built once ahead as a user would
                _timed(_eval(url, args, work / "warm", 1, "fast", 1))
            if picked("openpi"):
                rows.append(run_openpi(args, url))
            for shards in (1, 2) if picked("vla-eval") else ():
                rows.append(run_vla_eval(args, shards))
            for envs in (1, 2) if picked("rlinf") else ():
                rows.append(run_rlinf(args, envs))
            for workers, quality in ((1, "full"), (2, "full"), (2, "fast")) if picked("ours") else ():
                rows.append(run_ours(args, url, work, workers, quality))
            for row in rows:
                print(json.dumps(row.__dict__), flush=True)
    finally:
        server.kill()
    body = table(rows, machine_limit(args), args)
    print(body)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(ROOT / "benchmarks" / "RESULTS.md", "Peers: LIBERO harnesses side by side", body)


if __name__ == "__main__":
    main()
