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
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("SVT_LOG", "1")

QUALITIES = ("full", "fast")


def rollouts(run: Path, workers: int) -> dict[Any, Any]:
    """Outcomes per (quality, start kind): {(task, rollout): (success, init index, seed)}."""
    from libero_bench.checkpoints import kept_checkpoint, policy_from_checkpoint
    from libero_bench.compare import final_outcomes
    from libero_bench.data import DemoDataset
    from libero_bench.evaluate import Evaluator, make_job
    from libero_bench.language import encode_tasks
    from libero_bench.plan import resolve_eval_task
    from libero_bench.run_files import HELDOUT, STORED, RunFolder
    from libero_bench.runs import load_run

    summary = load_run(run)
    config = summary.config
    preset = config["preset"]
    source = DemoDataset(config["data"])
    languages = [t["language"] for t in config["tasks"]]
    embs = encode_tasks(languages, preset["language_encoder"])
    out: dict[Any, Any] = {
        "run": str(run),
        "recorded": {s: final_outcomes(summary, s) for s in (STORED, HELDOUT)},
    }
    folder = RunFolder(run)
    seconds: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for position in range(summary.tasks_done):
            task = source.task(config["tasks"][position]["name"])
            eval_task = resolve_eval_task(
                source, task, position, embs[position], heldout=preset["eval_heldout"]
            )
            policy, _algo = policy_from_checkpoint(
                config, kept_checkpoint(folder, config, position), position
            )
            for quality in QUALITIES:
                jobs = []
                for start, count in ((STORED, preset["eval_rollouts"]), (HELDOUT, preset["eval_heldout"])):
                    for r in range(count):
                        key = f"{quality}-{position}-{start}-{r:03d}"
                        jobs.append(
                            make_job(
                                eval_task,
                                r,
                                key=key,
                                settle=preset["eval_settle"],
                                max_steps=preset["eval_max_steps"],
                                image_size=preset["image_size"],
                                sim_state_width=source.sim_state_width,
                                shard_dir=f"shards/{key}",
                                rrd_path=f"rrd/{key}.rrd",
                                tags={"quality": quality},
                                start=start,
                                render_quality=quality,
                            )
                        )
                started = time.perf_counter()
                with Evaluator(workers, Path(tmp) / quality) as evaluator:
                    results = evaluator.run(policy, jobs)
                seconds[quality] = seconds.get(quality, 0.0) + time.perf_counter() - started
                for job, result in zip(jobs, results, strict=True):
                    tags = job.tags
                    out.setdefault((quality, job.start), {})[(eval_task.name, int(tags["rollout"]))] = (
                        bool(result.success),
                        int(tags["init_index"]),
                        int(tags["env_seed"]),
                    )
    out["seconds"] = seconds
    return out


def table(found: list[dict[Any, Any]], workers: int) -> str:
    from libero_bench.compare import pair
    from libero_bench.run_files import HELDOUT, STORED

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
