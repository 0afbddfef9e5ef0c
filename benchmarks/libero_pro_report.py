"""Our committed libero_object policies under LIBERO-PRO and under the standard protocol, beside
our default protocol: the table RESULTS quotes, made from the committed evaluation folders.

The policies are the robustness-data runs on libero_object/0 (`benchmarks/results/robustness_data/
runs/`): A (`single-object-0`, the quick preset on 100 demonstrations), A with image augmentation
(`single-aug-object-0`), and B on three draws of every variant (`mixed-more-object-0`). Each was
evaluated with

    libero-bench eval RUN --benchmark libero-pro --tasks libero_object/0 --trials 10 --workers 2 --out DIR
    libero-bench eval RUN --tasks libero_object/0 --stored 10 --heldout 0 --workers 1 --out DIR/default

(``benchmarks/libero_pro.sh``). The standard protocol's episode i and the default protocol's stored
start i begin from the same stored init state (libero_object has no fixtures), so the two pair start
for start; so do two policies' episodes of one suite. Pairs are tested with McNemar's exact test.

    python -m benchmarks.libero_pro_report [--results benchmarks/results/libero_pro]
"""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from libero_bench.analysis.compare import Paired
from libero_bench.evaluation.libero_pro import COLUMNS
from libero_bench.runs.intervals import Rate

RUNS = Path(__file__).resolve().parent / "results" / "robustness_data" / "runs"
POLICIES = ("single-object-0", "single-aug-object-0", "mixed-more-object-0")
LABELS = {
    "single-object-0": "A (quick, 100 demonstrations)",
    "single-aug-object-0": "A with augmentation",
    "mixed-more-object-0": "B on three draws of the variants",
}
#: Pairs of policies compared column for column, start for start: (first, second).
PAIRS = (
    ("single-aug-object-0", "single-object-0"),
    ("mixed-more-object-0", "single-object-0"),
    ("mixed-more-object-0", "single-aug-object-0"),
)


def _outcomes(folder: Path) -> dict[int, bool]:
    """Success per stored init state of a one-task evaluation folder."""
    records = json.loads((folder / "results.json").read_text())["rollouts"]
    return {int(r["init_index"]): bool(r["success"]) for r in records}


def paired_outcomes(a: dict[Any, bool], b: dict[Any, bool]) -> dict[str, Any]:
    """``a`` and ``b`` on the keys both ran (Paired: ``a`` is the first's successes); ``{"n": 0}``
    where they share none."""
    keys = sorted(set(a) & set(b))
    if not keys:
        return {"n": 0}
    return Paired(
        a=sum(a[k] for k in keys),
        b=sum(b[k] for k in keys),
        only_a=sum(a[k] and not b[k] for k in keys),
        only_b=sum(b[k] and not a[k] for k in keys),
        n=len(keys),
    ).to_dict()


def summary(root: Path) -> dict[str, Any]:
    """The report's content from the committed folders under ``root``."""
    out: dict[str, Any] = {"columns": list(COLUMNS), "policies": {}, "pairs": []}
    suites: dict[str, dict[str, str]] = {}
    for policy in POLICIES:
        table = json.loads((root / policy / "libero_pro.json").read_text())
        (row,) = table["rows"]
        suites[policy] = {c: row["columns"][c]["suite"] for c in COLUMNS}
        standard = _outcomes(root / policy / row["columns"]["original"]["suite"])
        default = _outcomes(root / policy / "default")
        out["policies"][policy] = {
            "label": LABELS[policy],
            "columns": {c: row["columns"][c] for c in COLUMNS},
            "perturbed": row["perturbed"],
            "default_protocol": Rate(sum(default.values()), len(default)).to_dict(),
            "standard_against_default": paired_outcomes(standard, default),
        }
    for first, second in PAIRS:

        def outcomes(policy: str, column: str) -> dict[Any, bool]:
            return _outcomes(root / policy / suites[policy][column])

        per_column = {c: paired_outcomes(outcomes(first, c), outcomes(second, c)) for c in COLUMNS}
        perturbed = [c for c in COLUMNS if c != "original"]
        pooled = paired_outcomes(
            {(c, k): v for c in perturbed for k, v in outcomes(first, c).items()},
            {(c, k): v for c in perturbed for k, v in outcomes(second, c).items()},
        )
        out["pairs"].append({"first": first, "second": second, "columns": per_column, "perturbed": pooled})
    return out


def _cell(rate: dict[str, Any]) -> str:
    return f"{rate['successes']}/{rate['n']} ({rate['low']:.0%}–{rate['high']:.0%})"


def markdown(report: dict[str, Any]) -> str:
    cols = report["columns"]
    lines = [
        "# libero_object/0 policies under LIBERO-PRO and the standard protocol",
        "",
        "Success with n and 95% Wilson interval; 10 episodes per suite from stored init states 0–9. "
        "Default: our protocol from the same stored init states (policy's own image size, canonical "
        "reset); standard: openpi's LIBERO loop (256 px cameras sent as 224, LIBERO's reset and start). "
        "p: McNemar's exact test on the paired starts.",
        "",
        "| policy | default protocol | standard (original) | p | Obj | Pos | Sem | Task | perturbed, pooled |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in report["policies"].values():
        pair = row["standard_against_default"]
        lines.append(
            f"| {row['label']} | {_cell(row['default_protocol'])} | {_cell(row['columns']['original'])} "
            f"| {pair['p_value']:.3f} | "
            + " | ".join(_cell(row["columns"][c]) for c in cols[1:])
            + f" | {_cell(row['perturbed'])} |"
        )
    lines += [
        "",
        "Start for start between policies (successes of the first, of the second, p):",
        "",
        "| pair | " + " | ".join(cols) + " | perturbed, pooled |",
        "|---|" + "---:|" * (len(cols) + 1),
    ]
    for pair in report["pairs"]:
        name = f"{pair['first']} against {pair['second']}"
        cells = [pair["columns"][c] for c in cols] + [pair["perturbed"]]
        lines.append(
            f"| {name} | "
            + " | ".join(
                f"{p['a']['successes']} vs {p['b']['successes']} (p {p['p_value']:.3f})" for p in cells
            )
            + " |"
        )
    return "\n".join(lines) + "\n"


def name_policies(root: Path) -> None:
    """Name each policy in the copied reports from where they are committed: the reports were
    written in a work folder, and name the run relative to it."""
    from libero_bench.evaluation.libero_pro import pro_markdown

    rename_reports(root, POLICIES, "libero_pro.json", pro_markdown)


def rename_reports(
    root: Path, policies: Iterable[str], table: str, render_table: Callable[[Any], str]
) -> None:
    """In ``root/<policy>/``, the policy named from its committed run folder in the table (``table``,
    re-rendered by ``render_table``) and in each suite's ``report.json`` (re-rendered as an
    evaluation report)."""
    from libero_bench.evaluation.eval_report import eval_markdown
    from libero_data.runtime.files import write_json, write_text

    for policy in policies:
        for report in sorted((root / policy).glob("*.json")) + sorted((root / policy).glob("*/report.json")):
            summary = json.loads(report.read_text())
            summary["policy"] = os.path.relpath(RUNS / policy, report.parent.resolve())
            write_json(report, summary)
            render = render_table if report.name == table else eval_markdown
            write_text(report.with_suffix(".md"), render(summary))


def write_summary(root: Path, report: dict[str, Any], text: str) -> None:
    """``summary.json`` and ``summary.md`` of a benchmark's committed folders, and the text shown."""
    (root / "summary.json").write_text(json.dumps(report, indent=1, sort_keys=True) + "\n")
    (root / "summary.md").write_text(text)
    print(text)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--results", default="benchmarks/results/libero_pro", type=Path)
    args = parser.parse_args()
    name_policies(args.results)
    report = summary(args.results)
    write_summary(args.results, report, markdown(report))


if __name__ == "__main__":
    main()
