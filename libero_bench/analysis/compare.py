"""Comparing two runs on the same starts: McNemar's exact test on paired outcomes.

Both runs are evaluated from the same starts (stored init states, and held-out placements that
depend on the task only), so each start gives a pair of outcomes: the final checkpoint of run A
and of run B on that task from that start. Only the pairs where exactly one run succeeded say
which is better; McNemar's exact test asks whether those split evenly. The comparison is made
per task and pooled over the tasks both runs learned, for each kind of start.

FWT, NBT and AUC are compared through their difference (A - B) with its 95% bootstrap interval.
When both runs learned the same tasks and were evaluated alike (as two algorithms run with one
preset are), the bootstrap resamples the same starts in both, and a paired permutation test
(swapping the two runs' outcomes from a start at random; McNemar's test when the metric is one
success rate) says whether the difference is significant. Otherwise the runs are drawn
independently and a difference is called significant when its interval excludes zero.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from libero_bench.runs.folder import AFTER, LEARNING, STARTS, STORED
from libero_bench.runs.intervals import DRAWS, METRICS, interval, swap_test
from libero_bench.runs.summary import RunSummary, load_run
from libero_data.errors import RunError
from libero_data.stats import mcnemar_exact, wilson_interval

#: The level at which a difference is called significant.
ALPHA = 0.05


@dataclass(frozen=True)
class Paired:
    """Paired outcomes of two runs on one set of starts."""

    a: int  # successes of run A
    b: int  # successes of run B
    only_a: int
    only_b: int
    n: int

    @property
    def p_value(self) -> float:
        return mcnemar_exact(self.only_a, self.only_b)

    def to_dict(self) -> dict[str, Any]:
        a_low, a_high = wilson_interval(self.a, self.n)
        b_low, b_high = wilson_interval(self.b, self.n)
        return {
            "n": self.n,
            "a": {"successes": self.a, "rate": self.a / self.n, "low": a_low, "high": a_high},
            "b": {"successes": self.b, "rate": self.b / self.n, "low": b_low, "high": b_high},
            "only_a": self.only_a,
            "only_b": self.only_b,
            "p_value": self.p_value,
            "significant": self.p_value < ALPHA,
        }


def final_outcomes(run: RunSummary, start: str) -> dict[tuple[str, int], tuple[bool, int, int]]:
    """(task name, rollout) -> (success, init index, seed) of the final checkpoint's rollouts on
    each finished task: those after the last task, or for the task learned last (and for MTL)
    those of the kept epoch."""
    results, last, names = run.results, run.tasks_done - 1, run.learned
    out: dict[tuple[str, int], tuple[bool, int, int]] = {}
    after = {
        (r["task_position"], r["rollout"]): r
        for r in results.rollouts
        if r.get("start", STORED) == start and r["phase"] == AFTER and r["learned_after"] == last
    }
    for k in range(run.tasks_done):
        mine = [r for (pos, _), r in after.items() if pos == k]
        if not mine:
            epoch = results.eval_epochs[results.kept_index(k)]
            mine = [
                r
                for r in results.rollouts
                if r.get("start", STORED) == start
                and r["phase"] == LEARNING
                and r["task_position"] == k
                and r["epoch"] == epoch
            ]
        for r in mine:
            out[(names[k], int(r["rollout"]))] = (
                bool(r["success"]),
                int(r["init_index"]),
                int(r["env_seed"]),
            )
    return out


def pair(
    a: Mapping[tuple[str, int], tuple[bool, int, int]], b: Mapping[tuple[str, int], tuple[bool, int, int]]
) -> dict[str, Paired]:
    """Paired outcomes per task (the keys both have), checking that each pair shares its start."""
    tasks: dict[str, list[tuple[bool, bool]]] = {}
    for key in sorted(set(a) & set(b)):
        (ok_a, *start_a), (ok_b, *start_b) = a[key], b[key]
        if start_a != start_b:
            raise RunError(
                f"rollout {key[1]} of {key[0]} started from different states in the two runs "
                f"(init index and seed {tuple(start_a)} and {tuple(start_b)}); they cannot be paired"
            )
        tasks.setdefault(key[0], []).append((ok_a, ok_b))
    return {
        name: Paired(
            a=sum(x for x, _ in outcomes),
            b=sum(y for _, y in outcomes),
            only_a=sum(x and not y for x, y in outcomes),
            only_b=sum(y and not x for x, y in outcomes),
            n=len(outcomes),
        )
        for name, outcomes in tasks.items()
    }


def metric_differences(run_a: RunSummary, run_b: RunSummary, start: str) -> dict[str, Any] | None:
    """FWT, NBT and AUC of both runs from one kind of start, with the 95% bootstrap interval of
    A - B; None when the runs did not learn the same tasks in the same order."""
    if run_a.learned != run_b.learned or not (run_a.has(start) and run_b.has(start)):
        return None
    draws_a, draws_b = run_a.draws(start), run_b.draws(start)
    out: dict[str, Any] = {"paired": draws_a.layout == draws_b.layout, "metrics": {}}
    names = [
        name for name in METRICS if math.isfinite(draws_a.value(name)) and math.isfinite(draws_b.value(name))
    ]
    p_values = swap_test(draws_a, draws_b, names) if out["paired"] else {}
    for name in names:
        a, b = draws_a.value(name), draws_b.value(name)
        low, high = interval(draws_a.metric(name) - draws_b.metric(name))
        row: dict[str, Any] = {"a": a, "b": b, "difference": a - b, "low": low, "high": high}
        if out["paired"]:
            row["p_value"] = p_values[name]
            row["significant"] = bool(row["p_value"] < ALPHA)
        else:
            row["p_value"] = None
            row["significant"] = bool(low > 0 or high < 0)
        out["metrics"][name] = row
    return out


def compare_runs(path_a: str | Path, path_b: str | Path) -> dict[str, Any]:
    """The comparison of two runs (see the module docstring) as a JSON-ready dict."""
    run_a, run_b = load_run(path_a), load_run(path_b)
    out: dict[str, Any] = {"a": {"path": str(run_a.path), "label": run_a.label, "seed": run_a.config["seed"]}}
    out["b"] = {"path": str(run_b.path), "label": run_b.label, "seed": run_b.config["seed"]}
    out["alpha"] = ALPHA
    for start in STARTS:
        tasks = pair(final_outcomes(run_a, start), final_outcomes(run_b, start))
        if not tasks:
            out[start] = None
            continue
        total = Paired(
            *(sum(getattr(p, f) for p in tasks.values()) for f in ("a", "b", "only_a", "only_b", "n"))
        )
        out[start] = {"tasks": {name: p.to_dict() for name, p in tasks.items()}, "all": total.to_dict()}
        out[start]["difference"] = metric_differences(run_a, run_b, start)
    if out[STORED] is None and out.get("heldout") is None:
        raise RunError(f"{run_a.path} and {run_b.path} share no evaluated task; there is nothing to compare")
    return out


def verdict(row: Mapping[str, Any], a: str, b: str) -> str:
    """One comparison in words."""
    p = row["p_value"]
    if not row["only_a"] and not row["only_b"]:
        return f"{a} and {b} succeeded and failed on the same starts: no difference to test"
    better = a if row["a"]["successes"] > row["b"]["successes"] else b
    if row["significant"]:
        return f"{better} succeeds more often (McNemar exact p = {p:.3g} < {ALPHA})"
    return f"no significant difference (McNemar exact p = {p:.3g} ≥ {ALPHA})"


def metric_verdict(name: str, row: Mapping[str, Any], a: str, b: str) -> str:
    """One metric's difference in words."""
    p = row["p_value"]
    if p is None:
        why = "the interval of the difference " + ("excludes 0" if row["significant"] else "includes 0")
    else:
        why = f"paired permutation p = {p:.3g} {'<' if row['significant'] else '≥'} {ALPHA}"
        if p * (DRAWS + 1) < 1.5:  # no swap as far from 0: p is the least the draws can show
            why = f"paired permutation p ≤ {p:.1g}: none of {DRAWS} random swaps as far from 0"
    if not row["significant"]:
        return f"no significant difference ({why})"
    higher = a if row["difference"] > 0 else b
    return f"{higher}'s {name.upper()} is higher ({why})"


def _difference(row: Mapping[str, Any]) -> str:
    """'+0.55 [+0.40, +0.70]'"""
    return f"{row['difference']:+.2f} [{row['low']:+.2f}, {row['high']:+.2f}]"


def metric_line(name: str, row: Mapping[str, Any], a: str = "A", b: str = "B") -> str:
    """'NBT: A 0.60, B 0.05, A − B +0.55 [+0.40, +0.70]; ...'"""
    return (
        f"{name.upper()}: {a} {row['a']:.2f}, {b} {row['b']:.2f}, {a} − {b} {_difference(row)}; "
        + metric_verdict(name, row, a, b)
    )


def success_cells(row: Mapping[str, Any]) -> str:
    """'n | A | B | only A | only B | p' of a paired success row, for a Markdown table."""
    return (
        f"{row['n']} | {row['a']['successes']} | {row['b']['successes']} | "
        f"{row['only_a']} | {row['only_b']} | {row['p_value']:.3g}"
    )


def comparison_markdown(result: Mapping[str, Any]) -> str:
    """The comparison as a Markdown table, one row per task and kind of start."""
    a, b = result["a"]["label"] + " (A)", result["b"]["label"] + " (B)"
    lines = [
        f"# {a} vs {b}",
        "",
        f"A: `{result['a']['path']}`; B: `{result['b']['path']}`. Final checkpoints, paired on the same starts.",
        "",
        "| starts | task | n | A | B | only A | only B | p (McNemar exact) | verdict |",
        "|---|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for start in STARTS:
        block = result.get(start)
        if block is None:
            continue
        for name, row in [*block["tasks"].items(), ("all tasks", block["all"])]:
            lines.append(f"| {start} | {name} | {success_cells(row)} | {verdict(row, 'A', 'B')} |")
    rows = [(start, result[start]["difference"]) for start in STARTS if result.get(start)]
    rows = [(start, d) for start, d in rows if d and d["metrics"]]
    if rows:
        lines += [
            "",
            "FWT, NBT and AUC: the difference A − B with its 95% bootstrap interval"
            + (
                " (the same starts resampled in both runs) and a paired permutation test."
                if all(d["paired"] for _, d in rows)
                else " (runs drawn independently; not evaluated alike, so not paired)."
            ),
            "",
            "| starts | metric | A | B | A − B [95% interval] | verdict |",
            "|---|---|---:|---:|---:|---|",
        ]
        for start, d in rows:
            for name, row in d["metrics"].items():
                lines.append(
                    f"| {start} | {name.upper()} | {row['a']:.2f} | {row['b']:.2f} | {_difference(row)} | "
                    f"{metric_verdict(name, row, 'A', 'B')} |"
                )
    return "\n".join(lines) + "\n"
