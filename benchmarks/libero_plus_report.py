"""Our committed robustness-data policies under LIBERO-Plus: does variant data raise the score, per
category and in total, and by how much against image augmentation alone? The table RESULTS
quotes, made from the committed evaluation folders (``benchmarks/libero_plus.sh``).

For each task (libero_object/0, libero_spatial/8) three policies ran the same LIBERO-Plus tasks (20
runnable ones per category made from that task, drawn with seed 0), each once from init state 0
under the standard protocol: A (``single-*``: the quick preset on 100 demonstrations of the task),
A with image augmentation (``single-aug-*``) and B (``mixed-more-*``: the same recipe on three
draws of every variant of ours). Policies pair task for task; pairs are tested with McNemar's
exact test, per category and pooled.

    python -m benchmarks.libero_plus_report [--results benchmarks/results/libero_plus]

Writes ``summary.{json,md}`` and ``summary.png`` (each policy over both tasks, per category).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from benchmarks.libero_pro_report import paired_outcomes
from libero_bench.runs.intervals import Rate
from libero_data.tasks.plus import CATEGORIES, TITLES

RUNS = Path(__file__).resolve().parent / "results" / "robustness_data" / "runs"
TASKS = {"object-0": "libero_object/0", "spatial-8": "libero_spatial/8"}
KINDS = ("single", "single-aug", "mixed-more")
LABELS = {"single": "A", "single-aug": "A with augmentation", "mixed-more": "B (variant data)"}
#: Pairs compared category for category, task for task: (first, second).
PAIRS = (("mixed-more", "single"), ("single-aug", "single"), ("mixed-more", "single-aug"))


Outcomes = dict[str, dict[str, bool]]  # category -> task name -> success


def _outcomes(root: Path, policy: str) -> Outcomes:
    """Category -> task name -> success, from a policy's table and its suites' rollouts (a task's
    name says its category: libero_data.tasks.plus.parse_name)."""
    from libero_data.tasks.plus import parse_name

    table = json.loads((root / policy / "libero_plus.json").read_text())
    out: Outcomes = {c: {} for c in CATEGORIES}
    for row in table["rows"]:
        records = json.loads((root / policy / row["folder"] / "results.json").read_text())["rollouts"]
        for r in records:
            out[parse_name(r["task"]).category][r["task"]] = bool(r["success"])
    return out


def summary(root: Path) -> dict[str, Any]:
    """The report's content from the committed folders under ``root`` (each policy read once)."""
    read: dict[str, dict[str, Outcomes]] = {}  # task short name -> kind -> outcomes
    for short in TASKS:
        present = [k for k in KINDS if (root / f"{k}-{short}" / "libero_plus.json").is_file()]
        if present:
            read[short] = {k: _outcomes(root, f"{k}-{short}") for k in present}
    out: dict[str, Any] = {"categories": list(CATEGORIES), "tasks": {}}
    for short, outcomes in read.items():
        out["tasks"][short] = {
            "task": TASKS[short],
            "policies": {kind: _rates(kind, cats) for kind, cats in outcomes.items()},
            "pairs": [
                _pair(first, second, outcomes) for first, second in PAIRS if {first, second} <= set(outcomes)
            ],
        }
    every = [s for s in read if set(KINDS) <= set(read[s])]
    out["pooled_policies"] = {k: _rates(k, _merge(read, every, k)) for k in KINDS} if every else {}
    # Each pair over both tasks' LIBERO-Plus tasks together (the tasks are distinct, so their paired
    # outcomes pool into one McNemar test).
    out["pooled"] = []
    for first, second in PAIRS:
        both = [s for s in read if {first, second} <= set(read[s])]
        if both:
            merged = {k: _merge(read, both, k) for k in (first, second)}
            out["pooled"].append({**_pair(first, second, merged), "tasks": both})
    return out


def _merge(read: dict[str, dict[str, Outcomes]], shorts: list[str], kind: str) -> Outcomes:
    """A kind of policy's outcomes over several tasks, each task name prefixed by its task."""
    return {c: {f"{s}/{k}": v for s in shorts for k, v in read[s][kind][c].items()} for c in CATEGORIES}


def _pair(first: str, second: str, outcomes: dict[str, Outcomes]) -> dict[str, Any]:
    """Two kinds task for task, per category and over all categories."""
    a, b = outcomes[first], outcomes[second]

    def every(cats: Outcomes) -> dict[str, bool]:
        return {f"{c}/{k}": v for c in CATEGORIES for k, v in cats[c].items()}

    return {
        "first": first,
        "second": second,
        "cells": {c: paired_outcomes(a[c], b[c]) for c in CATEGORIES},
        "total": paired_outcomes(every(a), every(b)),
    }


def _rates(kind: str, cats: Outcomes) -> dict[str, Any]:
    """A policy's success per category and in total, from its outcomes by category."""
    every = [v for c in CATEGORIES for v in cats[c].values()]
    return {
        "label": LABELS[kind],
        "cells": {c: Rate(sum(cats[c].values()), len(cats[c])).to_dict() for c in CATEGORIES},
        "total": Rate(sum(every), len(every)).to_dict(),
    }


def _cell(rate: dict[str, Any]) -> str:
    if not rate["n"]:
        return "–"
    return f"{rate['successes']}/{rate['n']} ({rate['low']:.0%}–{rate['high']:.0%})"


def _pair_cell(p: dict[str, Any]) -> str:
    if not p["n"]:
        return "–"
    diff = (p["a"]["successes"] - p["b"]["successes"]) / p["n"]
    shown = "p < 0.001" if p["p_value"] < 0.001 else f"p {p['p_value']:.3f}"
    return f"{diff:+.0%} ({p['only_a']}:{p['only_b']}, {shown})"


def _rate_table(rows: Any) -> list[str]:
    """A markdown table of policies' rates per category and in total."""
    lines = ["", "| policy | " + " | ".join(TITLES[c] for c in CATEGORIES) + " | Total |"]
    lines.append("|---|" + "---:|" * (len(CATEGORIES) + 1))
    for row in rows:
        cells = " | ".join(_cell(row["cells"][c]) for c in CATEGORIES)
        lines.append(f"| {row['label']} | {cells} | {_cell(row['total'])} |")
    return lines


def _pair_table(pairs: Any) -> list[str]:
    """A markdown table of pairs' paired differences per category and in total."""
    lines = ["", "| pair | " + " | ".join(TITLES[c] for c in CATEGORIES) + " | Total |"]
    lines.append("|---|" + "---:|" * (len(CATEGORIES) + 1))
    for pair in pairs:
        name = f"{LABELS[pair['first']]} − {LABELS[pair['second']]}"
        cells = " | ".join(_pair_cell(pair["cells"][c]) for c in CATEGORIES)
        lines.append(f"| {name} | {cells} | {_pair_cell(pair['total'])} |")
    return lines


def markdown(report: dict[str, Any]) -> str:
    lines = [
        "# Robustness-data policies under LIBERO-Plus",
        "",
        "LIBERO-Plus tasks made from each policy's own task, 20 runnable per category (seed 0; the same "
        "tasks for every policy), each once from init state 0 under the standard protocol. Success with n "
        "and 95% Wilson interval. Pairs: the difference in success, the discordant tasks (first only : "
        "second only) and McNemar's exact p.",
    ]
    for entry in report["tasks"].values():
        lines += ["", f"## {entry['task']}"]
        lines += _rate_table(entry["policies"].values()) + _pair_table(entry["pairs"])
    if report.get("pooled"):
        lines += ["", "## Both tasks pooled"]
        if report.get("pooled_policies"):
            lines += _rate_table(report["pooled_policies"].values())
        lines += _pair_table(report["pooled"])
    return "\n".join(lines) + "\n"


def chart(report: dict[str, Any], path: Path) -> None:
    """Each policy's success over both tasks per category and in total, with Wilson intervals."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt
    import numpy as np

    from libero_bench.evaluation.eval_report import interval_bars

    rows = report.get("pooled_policies") or {}
    columns = [c for c in CATEGORIES if any(r["cells"][c]["n"] for r in rows.values())]
    width = 0.8 / max(len(rows), 1)
    fig, ax = plt.subplots(figsize=(1.3 * len(columns) + 2.5, 3.4), dpi=120)
    for k, row in enumerate(rows.values()):
        x = np.arange(len(columns) + 1) + (k - (len(rows) - 1) / 2) * width
        interval_bars(ax, x, [*(row["cells"][c] for c in columns), row["total"]], width, row["label"])
    ax.set_xticks(range(len(columns) + 1), [*(TITLES[c] for c in columns), "Total"], fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success (95% Wilson)")
    tasks = ", ".join(e["task"] for e in report["tasks"].values())
    ax.set_title(f"LIBERO-Plus tasks made from {tasks}, pooled", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def name_policies(root: Path) -> None:
    """Name each policy in the copied reports from where they are committed (the reports were
    written in a work folder and name the run relative to it)."""
    from benchmarks.libero_pro_report import rename_reports
    from libero_bench.evaluation.libero_plus import plus_markdown

    policies = [f"{kind}-{short}" for short in TASKS for kind in KINDS if (root / f"{kind}-{short}").is_dir()]
    rename_reports(root, policies, "libero_plus.json", plus_markdown)


def main() -> None:
    from benchmarks.libero_pro_report import write_summary

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--results", default="benchmarks/results/libero_plus", type=Path)
    args = parser.parse_args()
    name_policies(args.results)
    report = summary(args.results)
    write_summary(args.results, report, markdown(report))
    chart(report, args.results / "summary.png")


if __name__ == "__main__":
    main()
