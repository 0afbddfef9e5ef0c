"""What ``libero-data import`` costs per 50 demonstrations: wall time and disk, on this machine.

A LIBERO-format HDF5 file of ``--demos`` expert episodes of ``--task`` (from its first stored init
states; written as LIBERO's ``create_dataset.py`` writes its files, by ``tests/hdf5/libero_files.py``)
is imported with ``libero-data import`` in a fresh process at 128x128 with both cameras, once per
``--workers`` value; prints a Markdown table (wall time, per demonstration, frames, dataset size),
and before it the checks alone (fixtures, one-step replay, the init state each began from), timed
in this process as the import's driver runs them before the workers render.
The demonstrations are the expert's, not LIBERO's human ones (which cannot be downloaded here):
LIBERO's are longer on most suites (human longest per suite 193-505 steps), and time scales with
frames. Run: ``python -m benchmarks.bench_import --task libero_spatial/2 --demos 50``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def folder_bytes(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def time_checks(source: Path, out: Path) -> float:
    """Seconds the import's checks of every demonstration in ``source`` take (one process)."""
    from libero_data.pipeline.importer import import_records, plan_import

    request, by_task = plan_import([source], out)
    work = out / "work"
    work.mkdir(parents=True)
    start = time.monotonic()
    import_records(request, by_task, work)
    return time.monotonic() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="libero_spatial/2")  # 50 of 50 for the expert
    parser.add_argument("--demos", type=int, default=50)
    parser.add_argument("--workers", default="2", help="comma-separated worker counts to time")
    parser.add_argument("--image-size", type=int, default=128)
    args = parser.parse_args()

    from libero_data.tasks import get_task
    from tests.hdf5.libero_files import expert_episodes, write_libero_file

    task = get_task(args.task)
    root = Path(tempfile.mkdtemp(prefix="bench-import-"))
    try:
        episodes = expert_episodes(task, list(range(args.demos)))
        source = write_libero_file(root / "files" / f"{task.name}_demo.hdf5", task, episodes)
        frames = sum(len(e.actions) - 5 for e in episodes)
        checks = time_checks(source, root / "checks")
        print(f"checks alone: {checks:.1f} s ({checks / args.demos:.2f} s per demonstration, one process)\n")
        print(
            f"| workers | wall (s) | per demonstration (s) | frames | dataset (MB) | task {task.id}, {args.demos} demonstrations, {args.image_size} px, 2 cameras |"
        )
        print("|---:|---:|---:|---:|---:|---|")
        for workers in [int(w) for w in args.workers.split(",")]:
            out = root / f"out-{workers}"
            env = {**os.environ, "OMP_NUM_THREADS": "1", "SVT_LOG": "1"}
            start = time.monotonic()
            result = subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "libero_data.cli",
                    "import",
                    str(source.parent),
                    "--out",
                    str(out),
                    "--workers",
                    str(workers),
                    "--image-size",
                    str(args.image_size),
                ],
                capture_output=True,
                text=True,
                env=env,
            )
            wall = time.monotonic() - start
            if result.returncode != 0:
                raise SystemExit(result.stderr[-2000:])
            info = json.loads((out / "meta" / "info.json").read_text())
            print(
                f"| {workers} | {wall:.0f} | {wall / args.demos:.1f} | {info['total_frames']} (source {frames}) | "
                f"{folder_bytes(out) / 1e6:.1f} | |"
            )
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
