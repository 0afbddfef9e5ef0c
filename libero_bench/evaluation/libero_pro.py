"""``libero-bench eval --benchmark libero-pro``: LIBERO-PRO's table (Zhou et al. 2025).

LIBERO-PRO perturbs each of LIBERO's four 10-task suites four ways (:func:`libero_data.tasks.pro_suite`):
other objects (``Obj``), other starting regions (``Pos``), a paraphrased instruction (``Sem``) and
another task in the same scene (``Task``). Its table gives, per suite, the success on the original
suite and on each family. Here every suite is evaluated under the standard protocol (openpi's LIBERO
loop: :mod:`libero_bench.rollouts.protocol`), each in its own resumable folder ``OUT/<suite>/``, with
``trials`` episodes per task; the table gives success with n and a 95% Wilson interval, the four
families pooled, and every suite pooled. The instruction a policy gets is the perturbed task's own
(the BDDL's sentence for ``Sem`` and ``Task``); LIBERO-PRO's own harness passes the original
instruction there, so its ``Sem`` column measures another thing.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from libero_bench.runs.intervals import Rate
from libero_data.errors import InputError
from libero_data.tasks.horizons import SUITE, StepLimit

BENCHMARK = "libero-pro"
ORIGINAL = "original"
#: LIBERO-PRO's table, column by column.
COLUMNS = (ORIGINAL, "Obj", "Pos", "Sem", "Task")


def pro_plan(refs: Sequence[str]) -> dict[str, list[str]]:
    """Base suite -> the task keys to evaluate in it and each of its families (indices, or names);
    an empty list: every task."""
    from libero_data.tasks import get_suite, pro_bases

    bases = list(pro_bases())
    plan: dict[str, list[str]] = {}
    for ref in refs:
        base, _, key = ref.partition("/")
        if base not in bases:
            raise InputError(
                f"LIBERO-PRO perturbs {', '.join(bases)}; {ref!r} is not one of them or a task of one",
                field="tasks",
            )
        chosen = plan.setdefault(base, [])
        if key:
            chosen.append(str(get_suite(base).task(key).index))
        elif chosen:
            raise InputError(f"{base} is named both whole and by task", field="tasks")
    return plan


def pro_columns(base: str) -> list[tuple[str, str]]:
    """(column, suite) of a base suite's row: the original, then its installed families."""
    from libero_data.tasks import pro_suite, pro_suite_names

    installed = set(pro_suite_names())
    columns = [(ORIGINAL, base)]
    for family in ("object", "swap", "lan", "task"):
        name = f"{base}_{family}"
        meaning = pro_suite(name)
        if name in installed and meaning is not None:
            columns.append((meaning.column, name))
    return columns


def evaluate_libero_pro(
    policy: str,
    refs: Sequence[str],
    out: str | Path,
    *,
    trials: int = 50,
    max_steps: StepLimit = SUITE,
    render_quality: str = "full",
    image_size: int | None = None,
    replan_steps: int = 5,
    execution: Any = None,
    keep_work: bool = False,
    on_result: Callable[[Any], None] | None = None,
    on_total: Callable[[int], None] | None = None,
) -> dict[str, Any]:
    """Evaluate ``policy`` on the base suites (or their tasks) of ``refs`` and their LIBERO-PRO
    families under the standard protocol; writes and returns the table."""
    from libero_bench.evaluation.policy_eval import EvalRequest, eval_records, evaluate_policy
    from libero_bench.rollouts.policy_kinds import policy_source, shown_from
    from libero_bench.rollouts.protocol import REQUEST_OPENPI
    from libero_data.runtime.files import write_json, write_text
    from libero_data.tasks import get_suite

    plan = pro_plan(refs)
    source = policy_source(policy, image_size, replan_steps, REQUEST_OPENPI)  # one sentence before any output
    out = Path(out)
    runs = [(base, column, suite) for base in plan for column, suite in pro_columns(base)]
    if on_total:
        on_total(sum(len(plan[b]) or len(get_suite(b)) for b, _, _ in runs) * trials)
    rows: list[dict[str, Any]] = []
    for base in plan:
        row: dict[str, Any] = {"suite": base, "columns": {}}
        for column, suite in pro_columns(base):
            tasks = tuple(f"{suite}/{k}" for k in plan[base]) or (suite,)
            request = EvalRequest(
                policy,
                tasks,
                protocol="standard",
                trials=trials,
                max_steps=max_steps,
                render_quality=render_quality,
                image_size=image_size,
                replan_steps=replan_steps,
            )
            summary = evaluate_policy(
                request,
                out / suite,
                execution=execution,
                on_result=on_result,
                source=source,
                keep_work=keep_work,
            )
            wins = [bool(r["success"]) for r in eval_records(out / suite)]
            row["columns"][column] = {
                "suite": suite,
                "folder": suite,
                **Rate(sum(wins), len(wins)).to_dict(),
                "standard": summary["standard"],
            }
        perturbed = [c for name, c in row["columns"].items() if name != ORIGINAL]
        row["perturbed"] = _pooled(perturbed)
        rows.append(row)
    table = {
        "benchmark": BENCHMARK,
        "policy": shown_from(source.ref, out),
        "policy_given": str(policy),  # as the user named it (the report shows this)
        "policy_type": source.policy_type,
        "trials_per_task": trials,
        "columns": list(COLUMNS),
        "tasks": {base: plan[base] or "all" for base in plan},
        "rows": rows,
        "all": {
            column: _pooled([r["columns"][column] for r in rows if column in r["columns"]])
            for column in COLUMNS
        }
        | {"perturbed": _pooled([r["perturbed"] for r in rows])},
        "standard": all(c["standard"] for r in rows for c in r["columns"].values()),
    }
    write_json(out / "libero_pro.json", table)
    write_text(out / "libero_pro.md", pro_markdown(table))
    pro_chart(table, out / "libero_pro.png")
    return table


def _pooled(cells: Sequence[dict[str, Any]]) -> dict[str, Any] | None:
    cells = [c for c in cells if c]
    if not cells:
        return None
    return Rate(sum(int(c["successes"]) for c in cells), sum(int(c["n"]) for c in cells)).to_dict()


def pro_markdown(table: dict[str, Any]) -> str:
    """LIBERO-PRO's table as Markdown."""

    def cell(rate: dict[str, Any] | None) -> str:
        if not rate:
            return "–"
        return f"{rate['rate']:.0%} ({rate['successes']}/{rate['n']}, {rate['low']:.0%}–{rate['high']:.0%})"

    columns = list(COLUMNS)
    lines = [
        f"# LIBERO-PRO: the {table['policy_type']} policy",
        "",
        f"Policy: `{table.get('policy_given') or table['policy']}`. Standard protocol (openpi's LIBERO loop), {table['trials_per_task']} "
        "episodes per task from stored init states 0..N-1 of each suite; success with n and 95% Wilson "
        "interval. Obj: objects changed; Pos: objects start elsewhere; Sem: the instruction paraphrased; "
        "Task: another task in the same scene. The policy gets each perturbed task's own instruction "
        "(LIBERO-PRO's harness gives Sem and Task the original one)."
        + ("" if table["standard"] else " **Not the standard protocol** in some suite: see its report."),
        "",
        "| suite | " + " | ".join(columns) + " | perturbed (pooled) |",
        "|---|" + "---:|" * (len(columns) + 1),
    ]
    for row in table["rows"]:
        lines.append(
            f"| {row['suite']} | "
            + " | ".join(cell(row["columns"].get(c)) for c in columns)
            + f" | {cell(row['perturbed'])} |"
        )
    if len(table["rows"]) > 1:
        lines.append(
            "| **all** | "
            + " | ".join(cell(table["all"].get(c)) for c in columns)
            + f" | {cell(table['all']['perturbed'])} |"
        )
    return "\n".join(lines) + "\n"


def pro_chart(table: dict[str, Any], path: Path) -> None:
    """Bars per suite and column with their intervals."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt
    import numpy as np

    from libero_bench.evaluation.eval_report import interval_bars

    columns = list(COLUMNS)
    rows = table["rows"]
    width = 0.8 / len(columns)
    fig, ax = plt.subplots(figsize=(2.0 + 1.6 * len(rows), 3.2), dpi=120)
    for i, column in enumerate(columns):
        x = np.arange(len(rows)) + (i - (len(columns) - 1) / 2) * width
        interval_bars(ax, x, [r["columns"].get(column) for r in rows], width, column)
    ax.set_xticks(range(len(rows)), [r["suite"] for r in rows])
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success (95% Wilson)")
    ax.set_title(f"LIBERO-PRO: {table['policy_type']}", fontsize=9)
    ax.legend(fontsize=7, ncol=5)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
