"""Two expert reports task for task, for pace (issue 74): success at all and within the standard
step limit, and the successful episodes' lengths, before and after; per suite the same with the
95th-percentile length against LIBERO's longest human demonstration.

    python -m benchmarks.compare_expert_pace benchmarks/results/expert_before_74/expert_report.jsonl \
        cards/expert_report.jsonl --out benchmarks/results/expert_pace/main.md

A task's change in success is called beyond chance where Fisher's exact test on the two 2x2 counts
(50 starts each: the same stored init states and seeds, other expert code) gives p < 0.05; the
rest of the table is counts and lengths as measured.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.cards.expert_table import summarise, task_limit, task_within
from libero_data.experts.report import TaskResult, read_report
from libero_data.runtime.files import write_text
from libero_data.stats import fisher_exact
from libero_data.tasks.horizons import HUMAN_LONGEST, base_suite


def _suite_line(suite: str, before: list[TaskResult], after: list[TaskResult]) -> str:
    def cells(rows: list[TaskResult]) -> tuple[str, str, str, str]:
        t = summarise(rows)[suite]
        lengths = [x for r in rows for x in r.lengths]
        return (
            f"{t['rate']:.1%} ({t['low']:.1%}–{t['high']:.1%})",
            f"{t['within_rate']:.1%} ({t['within_low']:.1%}–{t['within_high']:.1%})",
            f"{np.mean(lengths):.0f}" if lengths else "–",
            f"{np.percentile(lengths, 95):.0f}" if lengths else "–",
        )

    b, a = cells(before), cells(after)
    base = base_suite(suite) or suite
    human = HUMAN_LONGEST.get(base)
    return (
        f"| {suite} | {b[0]} | **{a[0]}** | {b[1]} | **{a[1]}** | {b[2]} → {a[2]} | {b[3]} → **{a[3]}** "
        f"| {human if human is not None else '–'} |"
    )


def compare(old: Path, new: Path) -> tuple[str, dict[str, Any]]:
    """The Markdown and a JSON summary of two reports' common tasks."""
    old_header, old_rows = read_report(old)
    new_header, new_rows = read_report(new)
    refs = [ref for ref in new_rows if ref in old_rows]
    suites = list(dict.fromkeys(new_rows[ref].suite for ref in refs))
    lines = [
        f"# The expert before and after issue 74: `{old_header['settings']['expert']}` → "
        f"`{new_header['settings']['expert']}`",
        "",
        f"{len(refs)} tasks measured by both, {old_header['settings']['inits']} stored init states each, the same "
        "seeds. Success and success within the standard step limit with 95% Wilson intervals; lengths of the "
        "successful episodes in control steps (20 Hz), the 95th percentile beside LIBERO's longest human "
        "demonstration of the (base) suite.",
        "",
        "| suite | success before | success after | within the limit before | within the limit after "
        "| mean length | 95th percentile | LIBERO human longest |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for suite in suites:
        rows = [ref for ref in refs if new_rows[ref].suite == suite]
        lines.append(_suite_line(suite, [old_rows[r] for r in rows], [new_rows[r] for r in rows]))
    lines += [
        "",
        "Task for task (*p*: Fisher's exact test on success at all, where it changed; ▼ a loss beyond chance):",
        "",
        "| task | limit | success | within the limit | mean length | longest | p |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    worse: list[str] = []
    better: list[str] = []
    summary: dict[str, dict[str, object]] = {}
    for ref in refs:
        o, n = old_rows[ref], new_rows[ref]
        p = (
            fisher_exact(o.successes, o.episodes, n.successes, n.episodes)
            if o.successes != n.successes
            else 1.0
        )
        mark = ""
        if p < 0.05:
            mark = " ▼" if n.successes < o.successes else " ▲"
            (worse if n.successes < o.successes else better).append(ref)
        ow, nw = task_within(o), task_within(n)
        longest_o = max(o.lengths) if o.lengths else 0
        longest_n = max(n.lengths) if n.lengths else 0
        lines.append(
            f"| {ref} | {task_limit(n)} | {o.successes} → {n.successes}{mark} | {ow} → {nw} "
            f"| {o.mean_length:.0f} → {n.mean_length:.0f} | {longest_o} → {longest_n} "
            f"| {'' if p == 1.0 else f'{p:.2g}'} |"
        )
        summary[ref] = {
            "success": [o.successes, n.successes],
            "within": [ow, nw],
            "episodes": n.episodes,
            "mean_length": [round(o.mean_length, 1), round(n.mean_length, 1)],
            "p": p,
        }
    lines += [
        "",
        f"Success changed beyond chance (p < 0.05): lower on {len(worse)} task(s)"
        + (f" ({', '.join(worse)})" if worse else "")
        + f", higher on {len(better)}"
        + (f" ({', '.join(better)})" if better else "")
        + ".",
    ]
    return "\n".join(lines) + "\n", {"worse": worse, "better": better, "tasks": summary}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old", type=Path)
    parser.add_argument("new", type=Path)
    parser.add_argument("--out", type=Path, required=True, help="Markdown file (a .json beside it)")
    args = parser.parse_args(argv)
    text, data = compare(args.old, args.new)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_text(args.out, text)
    write_text(args.out.with_suffix(".json"), json.dumps(data, indent=1) + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
