"""Does the arm's starting pose matter? A run's kept checkpoint from its held-out placements,
with the arm at LIBERO's one initial pose and with the stored init states' joint noise.

LIBERO's stored init states hold the arm's joints at their initial angles plus Gaussian noise
of 0.02 rad; LIBERO's environment starts every reset without it (libero_data.sim.arm). Each
held-out placement of the run is rolled out twice, ``fast`` images, once per arm pose; the
pairs are compared with McNemar's exact test. Prints Markdown.

    python -m benchmarks.bench_arm_noise RUN... [--data DATASET] [--workers 2]
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("SVT_LOG", "1")

from libero_data.sim.arm import ARM_INIT_NOISE

CONDITIONS = {
    "one arm pose": {"render_quality": "fast", "arm_noise": 0.0},
    f"arm noise {ARM_INIT_NOISE:g} rad": {"render_quality": "fast", "arm_noise": ARM_INIT_NOISE},
}


def table(found: list[dict[Any, Any]]) -> str:
    from libero_bench.analysis.compare import pair
    from libero_bench.runs.folder import HELDOUT, STORED

    a, b = CONDITIONS
    lines = [
        f"| run | n | recorded (stored starts) | recorded (held out) | {a} | {b} | only {a} / only {b} | p |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for f in found:
        rec = {s: sum(v[0] for v in f["recorded"][s].values()) for s in (STORED, HELDOUT)}
        n_rec = {s: len(f["recorded"][s]) for s in (STORED, HELDOUT)}
        for _task, p in pair(f[(a, HELDOUT)], f[(b, HELDOUT)]).items():
            d = p.to_dict()
            lines.append(
                f"| `{Path(f['run']).name}` | {p.n} | {rec[STORED]}/{n_rec[STORED]} | {rec[HELDOUT]}/{n_rec[HELDOUT]} | "
                f"{p.a}/{p.n} ({d['a']['low']:.2f}–{d['a']['high']:.2f}) | "
                f"{p.b}/{p.n} ({d['b']['low']:.2f}–{d['b']['high']:.2f}) | {p.only_a} / {p.only_b} | {d['p_value']:.3f} |"
            )
    return "\n".join(lines) + "\n"


def main() -> None:
    from benchmarks.reroll import reroll

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--data", type=Path, help="the runs' dataset, where it has moved since")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    found = [
        reroll(run, CONDITIONS, workers=args.workers, starts=("heldout",), data=args.data)
        for run in args.runs
    ]
    print(table(found))


if __name__ == "__main__":
    main()
