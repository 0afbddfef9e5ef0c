"""The standard protocol's throughput against openpi's LIBERO client loop, same machine, same policy.

The policy is a stand-in for an accelerator: a server (``libero_bench.rollouts.server.PolicyServer``,
what ``libero-bench serve`` runs) whose every forward pass takes ``--latency`` seconds whatever the
batch (up to 8) and answers chunks of ``--chunk`` actions. Measured, each as a user runs it (the
wall time of the whole command, start-up included), on the same task and episodes:

- openpi's loop: its client loop rebuilt from its documented steps (``benchmarks/openpi_loop.py``:
  LIBERO's ``OffScreenRenderEnv``, one episode after the other);
- ``libero-bench eval --protocol standard --server`` with 1 and 2 workers (full rendering), and with
  2 workers and ``--render-quality fast`` (not the standard: its images are not LIBERO's).

Every episode runs ``--max-steps`` after the 10 waiting steps (the stand-in never succeeds).
Rollouts per minute side by side, the ratio to openpi's loop, and where an evaluation's time went
(``results.json``: the driver's phases and the workers' summed over rollouts). ``--phases N``
instead runs ``eval`` on 1 and on N rollouts and prints each phase per rollout.

    python -m benchmarks.bench_standard_eval --results
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("SVT_LOG", "1")


def latency_server(port: int, latency: float, chunk: int) -> None:
    """Serve the stand-in policy until killed."""
    import asyncio

    import numpy as np

    from libero_bench.rollouts.actors import BatchActor, Observations
    from libero_bench.rollouts.server import PolicyServer

    class Accelerator(BatchActor):
        chunk_size = chunk

        def begin(self, slot: int, start: Any) -> None:
            pass

        def act(self, observations: Observations) -> dict[int, np.ndarray]:
            return {s: c[0] for s, c in self.act_chunks(observations).items()}

        def act_chunks(self, observations: Observations) -> dict[int, np.ndarray]:
            time.sleep(latency)  # one forward pass, the same at any batch size up to 8
            self.counted(len(observations))
            actions = np.zeros((chunk, 7))
            actions[:, 6] = -1.0
            actions[:, 0] = 0.2 * np.sin(np.arange(chunk))  # the arm moves: rendering is not of a still scene
            return {slot: actions for slot in observations}

    server = PolicyServer(Accelerator(), {"policy_type": f"stand-in ({latency * 1000:.0f} ms per pass)"})
    asyncio.run(server.serve("127.0.0.1", port))


def openpi_loop(url: str, task: str, episodes: int, max_steps: int) -> None:
    from benchmarks.openpi_loop import run_openpi_loop
    from libero_data.tasks import get_task

    run_openpi_loop(url, get_task(task), episodes, max_steps)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _timed(command: list[str]) -> float:
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    return time.perf_counter() - started


def _eval(
    url: str,
    args: argparse.Namespace,
    out: Path,
    workers: int,
    quality: str,
    trials: int,
    batch: int | None = None,
) -> list[str]:
    return [
        str(Path(sys.executable).parent / "libero-bench"),
        "eval",
        "--server",
        url,
        "--protocol",
        "standard",
        "--tasks",
        args.task,
        "--trials",
        str(trials),
        "--max-steps",
        str(args.max_steps),
        "--workers",
        str(workers),
        "--render-quality",
        quality,
        "--out",
        str(out),
        *(["--batch-size", str(batch)] if batch else []),
    ]


def _phases(folder: Path) -> dict[str, float]:
    sessions = json.loads((folder / "results.json").read_text())["sessions"]
    return dict(sessions[-1].get("phases", {}))


def stand_in_arguments(parser: argparse.ArgumentParser) -> None:
    """The task, episodes and stand-in policy every throughput benchmark against a peer takes."""
    parser.add_argument("--task", default="libero_object/0")
    parser.add_argument("--episodes", type=int, default=12)
    parser.add_argument(
        "--max-steps", type=int, default=280, help="Steps after the waits (libero_object's limit: 280)."
    )
    parser.add_argument("--latency", type=float, default=0.07, help="Seconds per forward pass.")
    parser.add_argument("--chunk", type=int, default=10, help="Actions per answer.")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    stand_in_arguments(parser)
    parser.add_argument(
        "--phases", type=int, default=0, help="Run eval on 1 and on N rollouts; print the phases."
    )
    parser.add_argument(
        "--results", action="store_true", help="Replace this benchmark's section of RESULTS.md."
    )
    parser.add_argument("--serve", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--openpi-loop", default="", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.serve:
        latency_server(args.serve, args.latency, args.chunk)
        return
    if args.openpi_loop:
        openpi_loop(args.openpi_loop, args.task, args.episodes, args.max_steps)
        return
    port = _free_port()
    url = f"ws://127.0.0.1:{port}"
    here = [sys.executable, "-m", "benchmarks.bench_standard_eval"]
    server = subprocess.Popen(
        [*here, "--serve", str(port), "--latency", str(args.latency), "--chunk", str(args.chunk)]
    )
    try:
        time.sleep(8)
        with tempfile.TemporaryDirectory(prefix="bench-standard-") as tmp:
            work = Path(tmp)
            if args.phases:
                print(_phase_table(url, args, work))
                return
            # fast rendering's simplified meshes are built once per scene, ahead, as a user would
            _timed(_eval(url, args, work / "warm", 1, "fast", 1))
            rows: list[tuple[str, float, dict[str, float] | None]] = []
            seconds = _timed(
                [
                    *here,
                    "--openpi-loop",
                    url,
                    "--task",
                    args.task,
                    "--episodes",
                    str(args.episodes),
                    "--max-steps",
                    str(args.max_steps),
                ]
            )
            rows.append(("openpi's loop (sequential, LIBERO's env)", seconds, None))
            for label, workers, quality, batch in (
                ("eval --protocol standard, 1 worker", 1, "full", None),
                ("eval --protocol standard, 2 workers", 2, "full", None),
                ("eval --protocol standard, 2 workers, 4 environments", 2, "full", 4),
                ("eval --protocol standard, 2 workers, fast (not the standard)", 2, "fast", None),
                (
                    "eval --protocol standard, 2 workers, 4 environments, fast (not the standard)",
                    2,
                    "fast",
                    4,
                ),
            ):
                out = work / f"{workers}-{quality}-{batch}"
                command = _eval(url, args, out, workers, quality, args.episodes, batch)
                rows.append((label, _timed(command), _phases(out)))
    finally:
        server.kill()
    body = _table(rows, args)
    print(body)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(
            Path(__file__).parent / "RESULTS.md", "Standard protocol: throughput against openpi's loop", body
        )


def _table(rows: list[tuple[str, float, dict[str, float] | None]], args: argparse.Namespace) -> str:
    base = args.episodes / rows[0][1] * 60
    lines = [
        f"Run: `python -m benchmarks.bench_standard_eval --episodes {args.episodes} --max-steps {args.max_steps} --results` "
        f"({args.task}; a stand-in policy server answering chunks of {args.chunk} after {args.latency * 1000:.0f} ms per "
        "forward pass at any batch size; every episode 10 waiting steps and "
        f"{args.max_steps} more; wall time of the whole command, start-up included).",
        "",
        "| how | seconds | rollouts per minute | against openpi's loop |",
        "|---|---:|---:|---:|",
    ]
    for label, seconds, _phases in rows:
        rate = args.episodes / seconds * 60
        lines.append(f"| {label} | {seconds:.1f} | {rate:.2f} | {rate / base:.2f}× |")
    lines += ["", "Where `eval`'s time went (seconds; the workers' phases summed over rollouts):", ""]
    names = sorted({k for _l, _s, p in rows if p for k in p})
    lines.append("| how | " + " | ".join(names) + " |")
    lines.append("|---|" + "---:|" * len(names))
    for label, _s, phases in rows:
        if phases:
            lines.append(f"| {label} | " + " | ".join(f"{phases.get(n, 0.0):.1f}" for n in names) + " |")
    return "\n".join(lines) + "\n"


def _phase_table(url: str, args: argparse.Namespace, work: Path) -> str:
    lines = ["| rollouts | wall s | " + "per rollout: phase s |", "|---:|---:|---|"]
    for n in (1, args.phases):
        out = work / f"phases-{n}"
        seconds = _timed(_eval(url, args, out, 2, "full", n))
        phases = _phases(out)
        shown = ", ".join(f"{k} {v / n:.2f}" for k, v in phases.items())
        lines.append(f"| {n} | {seconds:.1f} | {shown} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
