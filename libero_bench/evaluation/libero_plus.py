"""``libero-bench eval --benchmark libero-plus``: LIBERO-Plus's table (Fei et al. 2025).

LIBERO-Plus perturbs LIBERO's four 10-task suites in seven categories (camera, robot, language,
light, background, noise, layout; :mod:`libero_data.tasks.plus`). Their protocol: every task once,
from its init state 0, under LIBERO's loop (openpi's client: 10 waiting steps, the suite's step
limit); the table gives success per category and in total (pooled over tasks), per suite. Here each
base suite is evaluated under the standard protocol in its own resumable folder ``OUT/<suite>/``;
cells carry n and a 95% Wilson interval.

- **Which tasks.** ``--tasks``: a base suite (``libero_object`` or ``plus/libero_object``: all its
  tasks), a LIBERO task (``libero_object/0``: the LIBERO-Plus tasks made from it) or LIBERO-Plus
  tasks (``plus/libero_object/17``). Tasks that lack an asset (their light tasks, most backgrounds,
  added objects, without ``--plus-assets``) are counted as not run, per category.
- **A sample for CPU budgets.** ``per_category=N`` draws N runnable tasks per category and suite,
  stratified by difficulty where their ``task_classification.json`` gives it (its levels in turn),
  from ``seed``: the same tasks for every policy.
- **The prompt.** Each task's instruction (LIBERO's, or the rewritten one of a ``language`` task);
  ``prompt="file-name"`` sends what their benchmark sends, the file name's words with the
  perturbation's suffix (their tracker #46, #64), for comparison.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.runs.intervals import Rate
from libero_data.tasks.horizons import SUITE, StepLimit
from libero_data.tasks.plus import CATEGORIES, PREFIX, TITLES
from libero_data.tasks.plus_sample import plus_plan

BENCHMARK = "libero-plus"


def evaluate_libero_plus(
    policy: str,
    refs: Sequence[str],
    out: str | Path,
    *,
    per_category: int | None = None,
    seed: int = 0,
    prompt: str = "instruction",
    difficulty: dict[str, int] | None = None,
    max_steps: StepLimit = SUITE,
    render_quality: str = "full",
    image_size: int | None = None,
    replan_steps: int = 5,
    execution: Any = None,
    keep_work: bool = False,
    on_result: Callable[[Any], None] | None = None,
    on_total: Callable[[int], None] | None = None,
) -> dict[str, Any]:
    """Evaluate ``policy`` on the LIBERO-Plus tasks of ``refs`` (module docstring); writes and
    returns the table."""
    from libero_bench.evaluation.policy_eval import EvalRequest, eval_records, evaluate_policy
    from libero_bench.rollouts.policy_kinds import policy_source, shown_from
    from libero_bench.rollouts.protocol import REQUEST_OPENPI
    from libero_data.runtime.files import write_json, write_text
    from libero_data.tasks.plus_cache import plus_infos

    plan = plus_plan(refs, per_category, seed, difficulty)
    source = policy_source(policy, image_size, replan_steps, REQUEST_OPENPI)  # one sentence before any output
    out = Path(out)
    if on_total:
        on_total(sum(len(p["run"]) for p in plan.values()))
    rows: list[dict[str, Any]] = []
    for base, chosen in plan.items():
        infos = plus_infos(PREFIX + base)
        outcomes: dict[str, list[bool]] = {c: [] for c in CATEGORIES}
        standard = True
        if chosen["run"]:
            request = EvalRequest(
                policy,
                tuple(f"{PREFIX}{base}/{i}" for i in chosen["run"]),
                protocol="standard",
                trials=1,
                max_steps=max_steps,
                render_quality=render_quality,
                image_size=image_size,
                replan_steps=replan_steps,
                prompt=prompt,
            )
            summary = evaluate_policy(
                request,
                out / base,
                execution=execution,
                on_result=on_result,
                source=source,
                keep_work=keep_work,
            )
            standard = bool(summary["standard"])
            by_name = {infos[i].parsed.name: infos[i].category for i in chosen["run"]}
            for record in eval_records(out / base):
                outcomes[by_name[record["task"]]].append(bool(record["success"]))
        rows.append(
            {
                "suite": base,
                "folder": base,
                "cells": {c: Rate(sum(o), len(o)).to_dict() for c, o in outcomes.items()},
                "total": Rate(
                    sum(sum(o) for o in outcomes.values()), sum(len(o) for o in outcomes.values())
                ).to_dict(),
                "not_run": chosen["not_run"],
                "standard": standard,
            }
        )
    table = {
        "benchmark": BENCHMARK,
        "policy": shown_from(source.ref, out),
        "policy_given": str(policy),  # as the user named it (the report shows this)
        "policy_type": source.policy_type,
        "tasks": list(refs),
        "per_category": per_category,
        "seed": seed,
        "prompt": prompt,
        "categories": list(CATEGORIES),
        "rows": rows,
        "all": _all(rows),
        "standard": all(r["standard"] for r in rows),
    }
    write_json(out / "libero_plus.json", table)
    write_text(out / "libero_plus.md", plus_markdown(table))
    plus_chart(table, out / "libero_plus.png")
    return table


def _all(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Every suite pooled: per category, in total, and the tasks not run."""

    def pooled(cells: list[dict[str, Any]]) -> dict[str, Any]:
        return Rate(sum(int(c["successes"]) for c in cells), sum(int(c["n"]) for c in cells)).to_dict()

    not_run: dict[str, int] = {}
    for r in rows:
        for c, k in r["not_run"].items():
            not_run[c] = not_run.get(c, 0) + int(k)
    return {
        "cells": {c: pooled([r["cells"][c] for r in rows]) for c in CATEGORIES},
        "total": pooled([r["total"] for r in rows]),
        "not_run": not_run,
    }


def _cell(rate: dict[str, Any]) -> str:
    if not rate["n"]:
        return "–"
    return f"{rate['rate']:.0%} ({rate['successes']}/{rate['n']}, {rate['low']:.0%}–{rate['high']:.0%})"


def plus_markdown(table: dict[str, Any]) -> str:
    """LIBERO-Plus's table as Markdown: categories and total, per suite and pooled."""
    titles = [TITLES[c] for c in CATEGORIES]
    sample = (
        f"{table['per_category']} tasks per category and suite, drawn with seed {table['seed']}"
        if table["per_category"] is not None
        else "every task named"
    )
    prompt = (
        "each task's instruction (their file-name suffix left out)"
        if table["prompt"] == "instruction"
        else "the file-name prompt their benchmark builds (suffix included)"
    )
    lines = [
        f"# LIBERO-Plus: the {table['policy_type']} policy",
        "",
        f"Policy: `{table.get('policy_given') or table['policy']}`. LIBERO-Plus's protocol: each task once from its init state 0 under LIBERO's "
        f"loop (the standard protocol); {sample}; the prompt is {prompt}. Success with n and 95% Wilson "
        "interval; Total pools the tasks run, as their table does."
        + ("" if table["standard"] else " **Not the standard protocol** in some suite: see its report."),
        "",
        "| suite | " + " | ".join(titles) + " | Total |",
        "|---|" + "---:|" * (len(titles) + 1),
    ]
    for row in table["rows"]:
        lines.append(
            f"| {row['suite']} | "
            + " | ".join(_cell(row["cells"][c]) for c in CATEGORIES)
            + f" | {_cell(row['total'])} |"
        )
    if len(table["rows"]) > 1:
        everything = table["all"]
        lines.append(
            "| **all** | "
            + " | ".join(_cell(everything["cells"][c]) for c in CATEGORIES)
            + f" | {_cell(everything['total'])} |"
        )
    skipped = table["all"]["not_run"]
    if skipped:
        lines += [
            "",
            "Not run (their assets were not given): "
            + ", ".join(f"{TITLES[c]} {k}" for c, k in skipped.items())
            + ".",
        ]
    return "\n".join(lines) + "\n"


def plus_chart(table: dict[str, Any], path: Path) -> None:
    """Bars per category (and total) with their intervals, one group per suite."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    from libero_bench.evaluation.eval_report import interval_bars

    columns = [*CATEGORIES, "total"]
    rows = table["rows"]
    width = 0.8 / len(rows)
    fig, ax = plt.subplots(figsize=(1.2 * len(columns) + 1.5, 3.2), dpi=120)
    for k, row in enumerate(rows):
        cells = [row["cells"][c] if c != "total" else row["total"] for c in columns]
        x = np.arange(len(columns)) + (k - (len(rows) - 1) / 2) * width
        interval_bars(ax, x, cells, width, row["suite"])
    ax.set_xticks(range(len(columns)), [TITLES.get(c, "Total") for c in columns], fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success (95% Wilson)")
    ax.set_title(f"LIBERO-Plus: {table['policy_type']}", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
