"""Two methods compared over several seeds: each seed's pair of runs paired start for start,
the pairs pooled.

Runs of method A and of method B are matched by their seed (``config.json``'s ``seed``); every
matched pair learned the same tasks and was evaluated from the same starts, so within a pair each
start gives one outcome of A and one of B, as in :mod:`libero_bench.analysis.compare`. Pooled over
the pairs:

- Final success: McNemar's exact test on the discordant starts of every pair together (per task
  and over all tasks).
- FWT, NBT and AUC: A − B is the mean over seeds of each pair's difference. Its 95% interval is a
  two-level bootstrap (the pairs drawn with replacement, then each pair's starts, the same starts
  in both runs of a pair). Its p-value is a stratified paired permutation test: within every pair
  each start's two outcomes are swapped with probability 1/2, independently across pairs, and the
  mean difference recomputed; p is the share of draws at least as far from 0 as the observed one.
  The test asks whether the two methods differ on these seeds' runs (the pairs are fixed); the
  interval also counts the spread between seeds.

With one pair this is :func:`~libero_bench.analysis.compare.compare_runs`'s test and interval,
number for number.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.analysis.compare import (
    ALPHA,
    Paired,
    final_outcomes,
    metric_verdict,
    pair,
    success_cells,
)
from libero_bench.runs.folder import STARTS
from libero_bench.runs.intervals import DRAWS, METRICS, SEED, RunDraws, interval, permutation_p, swap_null
from libero_bench.runs.summary import RunSummary, load_run
from libero_data.errors import RunError


def pair_by_seed(
    runs_a: Sequence[RunSummary], runs_b: Sequence[RunSummary]
) -> list[tuple[int, RunSummary, RunSummary]]:
    """(seed, run of A, run of B) for every seed, in seed order; an error naming what does not
    match when a seed repeats within a method, or one method has a seed the other lacks."""
    by_seed: list[dict[int, RunSummary]] = []
    for runs in (runs_a, runs_b):
        seeds: dict[int, RunSummary] = {}
        for run in runs:
            seed = int(run.config["seed"])
            if seed in seeds:
                raise RunError(f"{seeds[seed].path} and {run.path} are both seed {seed} of one method")
            seeds[seed] = run
        by_seed.append(seeds)
    only = sorted(set(by_seed[0]) ^ set(by_seed[1]))
    if only:
        raise RunError(
            f"seed {only[0]} has a run of only one method ({(by_seed[0].get(only[0]) or by_seed[1][only[0]]).path}); "
            "each seed needs one run of each"
        )
    if not by_seed[0]:
        raise RunError("no runs to compare")
    return [(seed, by_seed[0][seed], by_seed[1][seed]) for seed in sorted(by_seed[0])]


def _success(pairs: Sequence[tuple[int, RunSummary, RunSummary]], start: str) -> dict[str, Any] | None:
    tasks: dict[str, list[Paired]] = {}
    by_seed: dict[str, Any] = {}
    for seed, run_a, run_b in pairs:
        paired = pair(final_outcomes(run_a, start), final_outcomes(run_b, start))
        if not paired:
            return None  # a pair not evaluated from this kind of start
        for name, p in paired.items():
            tasks.setdefault(name, []).append(p)
        by_seed[str(seed)] = _sum(list(paired.values())).to_dict()
    return {
        "tasks": {name: _sum(ps).to_dict() for name, ps in tasks.items()},
        "all": _sum([p for ps in tasks.values() for p in ps]).to_dict(),
        "by_seed": by_seed,
    }


def _sum(parts: Sequence[Paired]) -> Paired:
    return Paired(*(sum(getattr(p, f) for p in parts) for f in ("a", "b", "only_a", "only_b", "n")))


def _metrics(
    pairs: Sequence[tuple[int, RunSummary, RunSummary]], start: str, draws: int = DRAWS
) -> dict[str, Any] | None:
    """FWT, NBT and AUC pooled over the pairs (module docstring); None when a pair did not learn
    the same tasks or was not evaluated alike from this kind of start."""
    drawn = []
    for i, (_, run_a, run_b) in enumerate(pairs):
        if run_a.learned != run_b.learned or not (run_a.has(start) and run_b.has(start)):
            return None
        # Each pair gets its own draws (the same in both of its runs: paired start for start).
        a = RunDraws(run_a.results, run_a.tasks_done, start, draws, SEED + i)
        b = RunDraws(run_b.results, run_b.tasks_done, start, draws, SEED + i)
        if a.layout != b.layout:
            return None
        drawn.append((a, b))
    names = [
        name
        for name in METRICS
        if all(np.isfinite(a.value(name)) and np.isfinite(b.value(name)) for a, b in drawn)
    ]
    nulls = [swap_null(a, b, names, draws, SEED + i) for i, (a, b) in enumerate(drawn)]
    pick = np.random.default_rng(SEED + 1).integers(0, len(drawn), size=(draws, len(drawn)))
    out: dict[str, Any] = {"paired": True, "metrics": {}}
    for name in names:
        values_a = [a.value(name) for a, _ in drawn]
        values_b = [b.value(name) for _, b in drawn]
        difference = float(np.mean(values_a) - np.mean(values_b))
        per_pair = np.stack([a.metric(name) - b.metric(name) for a, b in drawn])  # (P, B)
        if len(drawn) > 1:  # the pairs drawn again, then each pair's starts
            per_pair = np.nanmean(per_pair[pick, np.arange(draws)[:, None]], axis=1)[None]
        low, high = interval(per_pair[0])
        p = permutation_p(difference, np.mean(np.stack([n[name] for n in nulls]), axis=0))
        out["metrics"][name] = {
            "a": float(np.mean(values_a)),
            "b": float(np.mean(values_b)),
            "difference": difference,
            "low": low,
            "high": high,
            "p_value": p,
            "significant": bool(p < ALPHA),
            "by_seed": {
                str(seed): va - vb for (seed, _, _), va, vb in zip(pairs, values_a, values_b, strict=True)
            },
        }
    return out


def compare_seeds(paths_a: Sequence[str | Path], paths_b: Sequence[str | Path]) -> dict[str, Any]:
    """Method A's runs against method B's, paired by seed and start (module docstring), as a
    JSON-ready dict shaped like :func:`~libero_bench.analysis.compare.compare_runs`'s (each
    kind of start's ``all``, ``tasks`` and ``difference``), with ``seeds`` and per-seed rows."""
    pairs = pair_by_seed([load_run(p) for p in paths_a], [load_run(p) for p in paths_b])
    first_a, first_b = pairs[0][1], pairs[0][2]
    out: dict[str, Any] = {
        "a": {"label": first_a.label, "paths": [str(r.path) for _, r, _ in pairs]},
        "b": {"label": first_b.label, "paths": [str(r.path) for _, _, r in pairs]},
        "seeds": [seed for seed, _, _ in pairs],
        "alpha": ALPHA,
    }
    for start in STARTS:
        block = _success(pairs, start)
        if block is not None:
            block["difference"] = _metrics(pairs, start)
        out[start] = block
    if all(out[start] is None for start in STARTS):
        raise RunError(
            f"{first_a.path} and {first_b.path} share no evaluated task; there is nothing to compare"
        )
    return out


def relative_paths(result: dict[str, Any], folder: Path) -> None:
    """Name the compared runs relative to ``folder`` (where the comparison is written), in place."""
    for side in ("a", "b"):
        result[side]["paths"] = [
            os.path.relpath(Path(p).resolve(), folder.resolve()) for p in result[side]["paths"]
        ]


def seeds_markdown(result: Mapping[str, Any]) -> str:
    """The pooled comparison as Markdown: success per task and per seed, then the metrics."""
    a, b = result["a"]["label"] + " (A)", result["b"]["label"] + " (B)"
    seeds = ", ".join(map(str, result["seeds"]))
    lines = [
        f"# {a} vs {b}, seeds {seeds}",
        "",
        "A: " + ", ".join(f"`{p}`" for p in result["a"]["paths"]),
        "",
        "B: " + ", ".join(f"`{p}`" for p in result["b"]["paths"]),
        "",
        "Final checkpoints, paired by seed and start; success pooled over the seeds (McNemar exact).",
        "",
        "| starts | task | n | A | B | only A | only B | p (McNemar exact) |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for start in STARTS:
        block = result.get(start)
        if block is None:
            continue
        rows = [*block["tasks"].items(), ("all tasks", block["all"])]
        rows += [(f"all tasks, seed {s}", row) for s, row in block["by_seed"].items()]
        for name, row in rows:
            lines.append(f"| {start} | {name} | {success_cells(row)} |")
    blocks = [(s, result[s]["difference"]) for s in STARTS if result.get(s) and result[s]["difference"]]
    if blocks:
        lines += [
            "",
            "FWT, NBT and AUC: A − B as the mean of the seeds' differences, its 95% interval a bootstrap "
            "over seeds and starts, its p a permutation test stratified by seed.",
            "",
            "| starts | metric | A | B | A − B [95% interval] | per seed | verdict |",
            "|---|---|---:|---:|---:|---|---|",
        ]
        for start, block in blocks:
            for name, row in block["metrics"].items():
                per_seed = ", ".join(f"{s}: {d:+.2f}" for s, d in row["by_seed"].items())
                lines.append(
                    f"| {start} | {name.upper()} | {row['a']:.2f} | {row['b']:.2f} | "
                    f"{row['difference']:+.2f} [{row['low']:+.2f}, {row['high']:+.2f}] | {per_seed} | "
                    f"{metric_verdict(name, row, 'A', 'B')} |"
                )
    return "\n".join(lines) + "\n"
