"""Does a policy trained on ``full``-quality images succeed as often on ``fast`` rollouts?

For each run folder given (single-task runs of the ``quick`` preset: ``benchmarks/quick.sh``),
the checkpoint the run kept is rolled out again from the run's own evaluation starts (its
stored init states and held-out placements), once with ``full`` and once with ``fast``
images, in this process's run; each start gives a pair of outcomes, compared with McNemar's
exact test. The ``full`` rollouts are also checked against the run's own recorded outcomes
(the same checkpoint from the same starts: they should agree start for start).

Prints Markdown and, with ``--results``, replaces the "Fast rendering: policy check" section
of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("SVT_LOG", "1")

QUALITIES = ("full", "fast")


def rollouts(run: Path, workers: int) -> dict[Any, Any]:
    """Outcomes per (quality, start kind): {(task, rollout): (success, init index, seed)}."""
    from benchmarks.reroll import reroll

    return reroll(run, {q: {"render_quality": q} for q in QUALITIES}, workers=workers)


def table(found: list[dict[Any, Any]], workers: int) -> str:
    from libero_bench.analysis.compare import pair
    from libero_bench.runs.folder import HELDOUT, STORED

    lines = [
        "Each run's kept checkpoint rolled out again from the run's own evaluation starts with `full` and with "
        f"`fast` images ({workers} rollout workers); paired per start, McNemar's exact test; rates with Wilson 95% "
        "intervals. *Recorded* is the run's own evaluation (full quality) of the same checkpoint. Run: "
        "`python -m benchmarks.bench_render_policy RUN...`.",
        "",
        "| run | starts | n | recorded full | full | fast | only full / only fast | p | full = recorded? |",
        "|---|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for f in found:
        for start in (STORED, HELDOUT):
            full, fast = f[("full", start)], f[("fast", start)]
            recorded = f["recorded"][start]
            same = sum(full[k][0] == recorded[k][0] for k in full if k in recorded)
            for _task, p in pair(full, fast).items():
                d = p.to_dict()
                rec = sum(recorded[k][0] for k in full if k in recorded)
                lines.append(
                    f"| `{Path(f['run']).name}` | {start} | {p.n} | {rec}/{p.n} | "
                    f"{p.a}/{p.n} ({d['a']['low']:.2f}–{d['a']['high']:.2f}) | "
                    f"{p.b}/{p.n} ({d['b']['low']:.2f}–{d['b']['high']:.2f}) | {p.only_a} / {p.only_b} | "
                    f"{d['p_value']:.2f} | {same}/{len(full)} starts |"
                )
    total = {q: sum(f["seconds"][q] for f in found) for q in QUALITIES}
    lines += [
        "",
        f"Rollout time, all runs: full {total['full']:.0f} s, fast {total['fast']:.0f} s "
        f"({total['full'] / total['fast']:.2f}×; policy inference and physics included).",
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--results", type=Path, help="RESULTS.md to update")
    args = parser.parse_args()
    found = [rollouts(run, args.workers) for run in args.runs]
    text = table(found, args.workers)
    print(text)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(args.results, "Fast rendering: policy check", text)


if __name__ == "__main__":
    main()
