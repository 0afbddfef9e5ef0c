"""The report of a policy evaluation: success per task from each kind of start with n and its
Wilson interval, each task's step limit and the rollouts it cut, and a bar chart."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.analysis.intervals import Rate
from libero_bench.runs.folder import HELDOUT, STARTS, STORED
from libero_data.tasks.horizons import limit_text

__all__ = ["chart", "eval_markdown", "summarize_eval"]


def summarize_eval(
    settings: dict[str, Any], records: list[dict[str, Any]], starts: dict[str, tuple[set[int], set[int]]]
) -> dict[str, Any]:
    """Per task and overall, the success from each kind of start with n and its interval, and
    how many rollouts the step limit cut (failed having taken every step they were allowed)."""
    rows = []
    totals = {start: Rate(0, 0) for start in STARTS}
    for task in settings["tasks"]:
        mine_all = [r for r in records if r["task_position"] == task["position"]]
        # Folders made before per-task limits hold one number in the request.
        limit = int(task.get("max_steps") or settings["request"]["max_steps"])
        row: dict[str, Any] = {
            "task": task["name"],
            "language": task["language"],
            "max_steps": limit,
            "cut": sum(1 for r in mine_all if not r["success"] and int(r["steps"]) >= limit),
        }
        for start in STARTS:
            mine = [
                r["success"]
                for r in records
                if r["task_position"] == task["position"] and r["start"] == start
            ]
            rate = Rate(sum(mine), len(mine))
            totals[start] = Rate(totals[start].successes + rate.successes, totals[start].n + rate.n)
            row[start] = rate.to_dict() if rate.n else None
        rows.append(row)
    notes = []
    if settings["training_data"] is None:
        notes.append(
            "the policy's training data is not known (a served policy, or a folder without train_config.json): "
            "held-out starts skip no training seed"
        )
    for task in settings["tasks"]:
        stored, _ = starts.get(task["name"], (set(), set()))
        evaluated = {
            r["init_index"]
            for r in records
            if r["task_position"] == task["position"] and r["start"] == STORED
        }
        if stored & evaluated:
            notes.append(
                f"the training data of {task['name']} began from {len(stored & evaluated)} of the stored init "
                "states it was evaluated from"
            )
    return {
        "policy": settings["request"]["policy"],
        "policy_type": settings["policy_type"],
        "max_steps": settings["request"]["max_steps"],
        "tasks": rows,
        "all": {
            **{start: totals[start].to_dict() if totals[start].n else None for start in STARTS},
            "cut": sum(row["cut"] for row in rows),
        },
        "notes": notes,
    }


def eval_markdown(summary: dict[str, Any]) -> str:
    def cell(rate: dict[str, Any] | None) -> str:
        if rate is None:
            return "–"
        return f"{rate['rate']:.0%} ({rate['successes']}/{rate['n']}, {rate['low']:.0%}–{rate['high']:.0%})"

    lines = [
        f"# {summary['policy_type']} policy: success in simulation",
        "",
        f"Policy: `{summary['policy']}`. Success with n and 95% Wilson interval; stored: LIBERO's stored init "
        "states (the paper's protocol); held out: placements no training demonstration started from. "
        f"Step limit: {limit_text(summary.get('max_steps', '?'))}. Cut: rollouts that failed having taken "
        "every step of their task's limit (a longer limit might have let them finish).",
        "",
        "| task | stored starts | held-out starts | step limit | cut by the step limit |",
        "|---|---:|---:|---:|---:|",
    ]
    for row in [*summary["tasks"], {"task": "**all tasks**", **summary["all"]}]:
        lines.append(
            f"| {row['task']} | {cell(row[STORED])} | {cell(row[HELDOUT])} | {row.get('max_steps', '')} "
            f"| {row.get('cut', '–')} |"
        )
    lines += [f"\n- note: {n}" for n in summary["notes"]]
    return "\n".join(lines) + "\n"


def chart(summary: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    rows = summary["tasks"]
    fig, ax = plt.subplots(figsize=(1.5 + 0.9 * len(rows), 3.2), dpi=120)
    for i, (start, colour) in enumerate(((STORED, "tab:blue"), (HELDOUT, "tab:orange"))):
        x = np.arange(len(rows)) + (i - 0.5) * 0.38
        y = np.array([r[start]["rate"] if r[start] else math.nan for r in rows])
        # Clipped at 0: a Wilson bound can lie a rounding error on the wrong side of the rate.
        low = np.array([max(r[start]["rate"] - r[start]["low"], 0.0) if r[start] else 0 for r in rows])
        high = np.array([max(r[start]["high"] - r[start]["rate"], 0.0) if r[start] else 0 for r in rows])
        ax.bar(x, y, width=0.38, color=colour, label=f"{start} starts")
        ax.errorbar(x, y, yerr=np.vstack([low, high]), fmt="none", ecolor="k", capsize=3)
    ax.set_xticks(range(len(rows)), [str(i) for i in range(len(rows))])
    ax.set_xlabel("task")
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success (95% Wilson)")
    ax.set_title(f"{summary['policy_type']} policy", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
