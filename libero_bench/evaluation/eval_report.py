"""The report of a policy evaluation: success per task from each kind of start with n and its
Wilson interval, each task's step limit and the rollouts it cut, the protocol and where the run
left its standard, and a bar chart."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.runs.folder import HELDOUT, STANDARD, START_KINDS, STORED
from libero_bench.runs.intervals import Rate
from libero_data.tasks.horizons import limit_text

__all__ = ["chart", "eval_markdown", "summarize_eval"]

KIND_TITLES = {STORED: "stored", HELDOUT: "held-out", STANDARD: "standard"}


def summarize_eval(
    settings: dict[str, Any], records: list[dict[str, Any]], starts: dict[str, tuple[set[int], set[int]]]
) -> dict[str, Any]:
    """Per task and overall, the success from each kind of start with n and its interval, and
    how many rollouts the step limit cut (failed having taken every step they were allowed)."""
    rows = []
    kinds = [k for k in START_KINDS if any(r["start"] == k for r in records)] or [STORED, HELDOUT]
    totals = {start: Rate(0, 0) for start in kinds}
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
        for start in kinds:
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
    if settings["training_data"] is None and any(r["start"] == HELDOUT for r in records):
        notes.append(
            "the policy's training data is not known (a served policy, or a folder without train_config.json): "
            "held-out starts skip no training seed"
        )
    for task in settings["tasks"]:
        stored, _ = starts.get(task["name"], (set(), set()))
        evaluated = {
            r["init_index"]
            for r in records
            if r["task_position"] == task["position"] and r["start"] in (STORED, STANDARD)
        }
        if stored & evaluated:
            notes.append(
                f"the training data of {task['name']} began from {len(stored & evaluated)} of the stored init "
                "states it was evaluated from"
            )
    protocol = settings.get("protocol") or {"name": "libero-bench", "deviations": []}
    if protocol["name"] == "standard":
        notes.extend(f"not the standard: {d}" for d in protocol["deviations"])
    return {
        "policy": settings["request"]["policy"],
        "policy_type": settings["policy_type"],
        "max_steps": settings["request"]["max_steps"],
        "protocol": protocol["name"],
        "standard": protocol["name"] == "standard" and not protocol["deviations"],
        "starts": kinds,
        "tasks": rows,
        "all": {
            **{start: totals[start].to_dict() if totals[start].n else None for start in kinds},
            "cut": sum(row["cut"] for row in rows),
        },
        "notes": notes,
    }


def eval_markdown(summary: dict[str, Any]) -> str:
    def cell(rate: dict[str, Any] | None) -> str:
        if rate is None:
            return "–"
        return f"{rate['rate']:.0%} ({rate['successes']}/{rate['n']}, {rate['low']:.0%}–{rate['high']:.0%})"

    kinds = summary.get("starts", [STORED, HELDOUT])
    if summary.get("protocol") == "standard":
        protocol = (
            "Protocol: standard, LIBERO's evaluation as openpi's LIBERO client runs it (episode i from stored "
            "init state i, fixtures as LIBERO's resets place them after seed 7, 10 waiting steps, openpi's "
            "request): "
            + (
                "identical to the published protocol."
                if summary.get("standard")
                else "**not the standard** (see the notes)."
            )
        )
        limit = "Step limit: each task's in the table (openpi's per suite unless a note says otherwise)."
        extra = summary.get("beyond_openpi")
        if extra:
            limit += (
                f" The policy also read {', '.join(f'`{e}`' for e in extra)}, sent beyond openpi's four entries "
                "(openpi's own LIBERO client does not send it)."
            )
        elif extra is not None:
            limit += " The policy read openpi's four entries only."
    else:
        protocol = (
            "Protocol: libero-bench; stored: LIBERO's stored init states (the paper's protocol); held out: "
            "placements no training demonstration started from."
        )
        limit = f"Step limit: {limit_text(summary.get('max_steps', '?'))}."
    lines = [
        f"# {summary['policy_type']} policy: success in simulation",
        "",
        f"Policy: `{summary.get('policy_given') or summary['policy']}`. Success with n and 95% Wilson interval. {protocol} {limit} Cut: rollouts "
        "that failed having taken every step of their task's limit (a longer limit might have let them finish).",
        "",
        "| task | "
        + " | ".join(f"{KIND_TITLES[k]} starts" for k in kinds)
        + " | step limit | cut by the step limit |",
        "|---|" + "---:|" * len(kinds) + "---:|---:|",
    ]
    for row in [*summary["tasks"], {"task": "**all tasks**", **summary["all"]}]:
        lines.append(
            f"| {row['task']} | "
            + " | ".join(cell(row.get(k)) for k in kinds)
            + f" | {row.get('max_steps', '')} | {row.get('cut', '–')} |"
        )
    lines += [f"\n- note: {n}" for n in summary["notes"]]
    return "\n".join(lines) + "\n"


def chart(summary: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    rows = summary["tasks"]
    kinds = summary.get("starts", [STORED, HELDOUT])
    colours = {STORED: "tab:blue", HELDOUT: "tab:orange", STANDARD: "tab:green"}
    width = 0.76 / len(kinds)
    fig, ax = plt.subplots(figsize=(1.5 + 0.9 * len(rows), 3.2), dpi=120)
    for i, start in enumerate(kinds):
        colour = colours[start]
        x = np.arange(len(rows)) + (i - (len(kinds) - 1) / 2) * width
        interval_bars(ax, x, [r[start] for r in rows], width, f"{start} starts", colour=colour)
    ax.set_xticks(range(len(rows)), [str(i) for i in range(len(rows))])
    ax.set_xlabel("task")
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success (95% Wilson)")
    ax.set_title(f"{summary['policy_type']} policy", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def interval_bars(
    ax: Any, x: Any, cells: list[dict[str, Any] | None], width: float, label: str, colour: str | None = None
) -> None:
    """Bars of success rates with their Wilson intervals; a cell without rollouts (None or n = 0)
    draws nothing."""
    present = [c if c and c.get("n") else None for c in cells]
    y = np.array([c["rate"] if c else math.nan for c in present], dtype=float)
    # Clipped at 0: a Wilson bound can lie a rounding error on the wrong side of the rate.
    low = np.array([max(c["rate"] - c["low"], 0.0) if c else 0.0 for c in present])
    high = np.array([max(c["high"] - c["rate"], 0.0) if c else 0.0 for c in present])
    ax.bar(x, y, width=width, color=colour, label=label)
    ax.errorbar(x, y, yerr=np.vstack([low, high]), fmt="none", ecolor="k", capsize=3)
