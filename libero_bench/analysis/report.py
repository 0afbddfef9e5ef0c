"""Reports over finished runs: FWT / NBT / AUC with 95% intervals, from LIBERO's stored init
states and from held-out placements; per-task success with n and Wilson intervals; a success
matrix, learning curves with error bars and a metrics chart (PNG); and a JSON with every number.

Runs are grouped by what they compare (algorithm, policy, preset and task list); the runs of a
group are its seeds. A run that stopped early is reported over the tasks it finished
(``tasks_done`` says so). Where a run's training data began from the stored evaluation starts,
the report says so. Needs numpy and matplotlib only (no torch).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.runs.folder import HELDOUT, STARTS, STORED
from libero_bench.runs.intervals import METRICS, Rate, final_rates, metric_summary
from libero_bench.runs.summary import RunSummary, load_run
from libero_data.errors import InputError
from libero_data.runtime.files import write_json, write_text


def _finite(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "-", text).strip("-").lower() or "run"


def _rows(matrix: np.ndarray) -> list[list[float | None]]:
    return [[_finite(v) for v in row] for row in matrix.tolist()]


def _run_row(run: RunSummary, out: Path) -> dict[str, Any]:
    row: dict[str, Any] = {
        "path": os.path.relpath(run.path.resolve(), out),
        "algo": run.config["algo"],
        "policy": run.config["policy"],
        "preset": run.config["preset"]["name"],
        "seed": run.config["seed"],
        "tasks": [t["name"] for t in run.config["tasks"]],
        "tasks_done": run.tasks_done,
        "complete": run.results.complete,
        "eval_epochs": run.results.eval_epochs,
        "best_epoch": run.results.best_epoch[: run.tasks_done],
        "losses": run.results.losses[: run.tasks_done],
        "step_limits": _step_limits(run),
        "notes": run.notes(),
    }
    for start in STARTS:
        if not run.has(start):
            row[start] = None
            continue
        curve, after = run.arrays(start)
        row[start] = {
            "curve": _rows(curve),
            "after": _rows(after),
            "final": [r.to_dict() for r in final_rates(run.results, run.tasks_done, start)],
            **metric_summary([run.draws(start)]),
        }
    return row


def _step_limits(run: RunSummary) -> dict[str, int]:
    """Per task of the run: the steps its evaluation rollouts were allowed (its preset's
    ``eval_max_steps``, a number or each task's suite limit; the dataset's suite)."""
    from libero_data.tasks.horizons import step_limit

    limit = run.config["preset"].get("eval_max_steps")
    if limit is None:
        return {}
    suite = str(run.config.get("dataset", {}).get("suite") or "")
    return {t["name"]: step_limit(limit, suite) for t in run.config["tasks"]}


def _group_row(key: tuple[Any, ...], members: list[RunSummary], slug: str, out: Path) -> dict[str, Any]:
    row: dict[str, Any] = {
        "label": members[0].label,
        "slug": slug,
        "algo": key[0],
        "policy": key[1],
        "preset": key[2],
        "tasks": list(key[3]),
        "runs": [os.path.relpath(m.path.resolve(), out) for m in members],
        "seeds": [m.config["seed"] for m in members],
        "tasks_done": min(m.tasks_done for m in members),
        "notes": [note for m in members for note in m.notes()],
    }
    k = row["tasks_done"]
    for start in STARTS:
        runs = [m for m in members if m.has(start)]
        if not runs:
            row[start] = None
            continue
        pooled = [Rate(0, 0)] * k
        for m in runs:
            for i, r in enumerate(final_rates(m.results, k, start)):
                pooled[i] = Rate(pooled[i].successes + r.successes, pooled[i].n + r.n)
        row[start] = {
            "final": [r.to_dict() for r in pooled],
            **metric_summary([m.draws(start) for m in runs]),
        }
    return row


def summarize(runs: Sequence[RunSummary], out: str | Path = ".") -> dict[str, Any]:
    """Every number of the report: per run, and per group of runs (the seeds of a method); run
    folders are named relative to ``out``, the report's folder."""
    out = Path(out).resolve()
    groups: dict[tuple[Any, ...], list[RunSummary]] = {}
    for run in runs:
        groups.setdefault(run.group, []).append(run)
    group_rows = []
    used: set[str] = set()
    labels = [members[0].label for members in groups.values()]
    for key, members in groups.items():
        row_label = members[0].label
        if labels.count(row_label) > 1:  # the same method on other tasks: name them
            row_label = f"{row_label} on {', '.join(key[3])}"
        slug = _slug(row_label if labels.count(members[0].label) > 1 else members[0].label)
        if slug in used:
            slug = f"{slug}-{len(used)}"
        used.add(slug)
        row = _group_row(key, members, slug, out)
        row["label"] = row_label
        group_rows.append(row)
    return {"runs": [_run_row(r, out) for r in runs], "groups": group_rows}


def _cell(stat: dict[str, Any] | None) -> str:
    if not stat or stat["mean"] is None:
        return "–"
    if stat["low"] is None:
        return f"{stat['mean']:.2f}"
    return f"{stat['mean']:.2f} [{stat['low']:.2f}, {stat['high']:.2f}]"


def _final_cell(final: list[dict[str, Any]]) -> str:
    return ", ".join(f"{f['successes']}/{f['n']}" for f in final)


TABLE_HEADER = [
    "method",
    "runs",
    "tasks",
    "starts",
    "FWT (↑)",
    "NBT (↓)",
    "AUC (↑)",
    "final success per task",
]
START_LABELS = {STORED: "stored", HELDOUT: "held out"}


def table_rows(summary: dict[str, Any]) -> list[list[str]]:
    """Rows of the headline table: per method and kind of start, FWT, NBT, AUC with their 95%
    intervals, and each task's final successes."""
    rows = []
    for g in summary["groups"]:
        for start in STARTS:
            numbers = g[start]
            if numbers is None:
                continue
            rows.append(
                [
                    g["label"],
                    f"{len(g['runs'])} (seeds {', '.join(map(str, g['seeds']))})",
                    f"{g['tasks_done']}/{len(g['tasks'])}",
                    START_LABELS[start],
                    *(_cell(numbers[m]) for m in METRICS),
                    _final_cell(numbers["final"]),
                ]
            )
    return rows


def markdown_table(summary: dict[str, Any]) -> str:
    lines = ["| " + " | ".join(TABLE_HEADER) + " |", "|" + "---|" * len(TABLE_HEADER)]
    lines += ["| " + " | ".join(row) + " |" for row in table_rows(summary)]
    text = "\n".join(lines) + "\n"
    text += (
        "\nIntervals: 95%, bootstrap over rollouts (over runs and rollouts where a method has several). "
        "Stored: LIBERO's stored init states (the paper's protocol); held out: placements no demonstration "
        "started from, which took no part in choosing checkpoints. Final success: the last checkpoint on each task.\n"
    )
    limits = sorted({n for r in summary["runs"] for n in r.get("step_limits", {}).values()})
    if limits:
        text += f"Evaluation rollouts were cut after {' or '.join(map(str, limits))} steps (per task: report.json).\n"
    notes = [n for g in summary["groups"] for n in g["notes"]]
    if notes:
        text += "\n" + "\n".join(f"- note: {n}" for n in notes) + "\n"
    return text


def write_report(run_paths: Sequence[str | Path], out: str | Path) -> dict[str, Any]:
    """Write ``report.json``, ``report.md`` and the PNGs into ``out``; returns the summary
    (with ``files``: what was written)."""
    from libero_bench.analysis.report_plots import group_plots, methods_plot

    if not run_paths:
        raise InputError("give at least one run folder", field="runs")
    runs = [load_run(p) for p in run_paths]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = summarize(runs, out)
    files = []
    for group in summary["groups"]:
        members = [r for r in runs if os.path.relpath(r.path.resolve(), out.resolve()) in group["runs"]]
        files.extend(group_plots(members, group, out))
    if len(summary["groups"]) > 1:
        files.append(methods_plot(summary["groups"], out))
    files.append(write_text(out / "report.md", "# libero-bench report\n\n" + markdown_table(summary)))
    summary["files"] = [os.path.relpath(p, out) for p in [*files, out / "report.json"]]
    write_json(out / "report.json", summary)
    return summary
