"""The LIBERO paper's lifelong algorithms and policy architectures on one libero_object sequence,
and its findings about them tested on our runs (issues 59 and 78). Made from the committed run
folders (``benchmarks/lifelong.sh``); RESULTS quotes what it writes. The findings and how each is
decided: ``benchmarks/lifelong_findings.py``.

The paper (LIBERO, Table VI, ResNet-T, three seeds) finds on LIBERO-Object: SeqL FWT 0.78, NBT 0.76,
AUC 0.26; ER 0.67 / 0.43 / 0.44; EWC 0.56 / 0.69 / 0.16; PackNet 0.60 / 0.17 / 0.60; MTL success 0.54.
Every run learned the same tasks from the same data and was evaluated from the same starts, so
two methods are compared over the seeds both have, paired by seed and start.

    python -m benchmarks.lifelong_report [--runs benchmarks/results/lifelong/runs] [--out benchmarks/results/lifelong]
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from benchmarks.lifelong_findings import (
    ALGO_NAMES,
    ALGOS,
    ALPHA,
    FINDINGS,
    POLICIES,
    POLICY_IDS,
    comparisons,
    display,
    findings,
    method_runs,
    missing_runs,
)

RESULTS = Path(__file__).resolve().parent / "results" / "lifelong"
#: The paper's LIBERO-Object row (Table VI, ResNet-T): FWT, NBT, AUC; MTL reports a success rate.
PAPER = {
    "seql": {"fwt": 0.78, "nbt": 0.76, "auc": 0.26},
    "er": {"fwt": 0.67, "nbt": 0.43, "auc": 0.44},
    "ewc": {"fwt": 0.56, "nbt": 0.69, "auc": 0.16},
    "packnet": {"fwt": 0.60, "nbt": 0.17, "auc": 0.60},
    "mtl": {"success": 0.54},
}
NAMES = ALGO_NAMES
#: The policy's name in a table row, where it is not the quick preset's ResNet-T.
POLICY_NAMES = {POLICY_IDS[suffix]: name for suffix, name in POLICIES.items() if suffix}


def _value(x: float | None) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:.2f}"


def _stat(stat: dict[str, Any] | None) -> str:
    if not stat or stat.get("mean") is None:
        return "–"
    if stat.get("low") is None:
        return f"{stat['mean']:.2f}"
    return f"{stat['mean']:.2f} [{stat['low']:.2f}, {stat['high']:.2f}]"


def table_markdown(report: dict[str, Any]) -> str:
    """Our rows (held-out and stored starts) beside the paper's LIBERO-Object row (ResNet-T's)."""
    lines = [
        "| algorithm | seeds | starts | FWT (↑) | NBT (↓) | AUC (↑) | final success | paper FWT / NBT / AUC |",
        "|---|---|---|---:|---:|---:|---:|---|",
    ]
    for group in report["groups"]:
        algo = group["algo"]
        paper = PAPER.get(algo, {}) if group["policy"] == "resnet_t" else {}
        name = NAMES.get(algo, algo) + (
            f" ({POLICY_NAMES[group['policy']]})" if POLICY_NAMES.get(group["policy"]) else ""
        )
        cited = (
            f"success {paper['success']:.2f}"
            if "success" in paper
            else " / ".join(f"{paper[m]:.2f}" for m in ("fwt", "nbt", "auc"))
            if paper
            else "–"
        )
        for start in ("heldout", "stored"):
            numbers = group.get(start)
            if numbers is None:
                continue
            successes = sum(f["successes"] for f in numbers["final"])
            n = sum(f["n"] for f in numbers["final"])
            lines.append(
                f"| {name} | {', '.join(map(str, group['seeds']))} | {start.replace('heldout', 'held out')} | "
                f"{_stat(numbers['fwt'])} | {_stat(numbers['nbt'])} | {_stat(numbers['auc'])} | "
                f"{successes}/{n} | {cited} |"
            )
    return "\n".join(lines) + "\n"


def findings_markdown(entries: list[dict[str, Any]]) -> str:
    lines = []
    for i, entry in enumerate(entries, 1):
        head = entry["heldout"]["verdict"]
        lines += [
            "",
            f"### {i}. {entry['text']}: {head} (held-out starts); {entry['stored']['verdict']} (stored starts)",
            "",
        ]
        if entry["untested"]:
            lines += [f"Not tested: {entry['untested']}.", ""]
        if entry.get("missing_runs"):
            names = ", ".join(display(m) for m in entry["missing_runs"])
            lines += [f"Not run yet: {names} (`benchmarks/lifelong.sh arch`).", ""]
        for start in ("heldout", "stored"):
            rows = [r for r in entry[start]["rows"] if r["tested"]]
            if not rows:
                continue
            lines += [
                f"{start.replace('heldout', 'Held-out')} starts:".capitalize(),
                "",
                "| claim | seeds | subject | other | difference [95% interval] | p | Holm p |",
                "|---|---|---:|---:|---:|---:|---:|",
            ]
            for r in rows:
                subject, metric, other = display(r["subject"]), r["metric"].upper(), display(r["other"])
                claim = (
                    f"{subject} {metric} against {other}"
                    if r["claimed"] == "either"
                    else f"{subject} {metric} {r['claimed']} than {other}"
                )
                p = "– (not paired)" if r["p_value"] is None else f"{r['p_value']:.3g}"
                lines.append(
                    f"| {claim} | {', '.join(map(str, r['seeds']))} | {_value(r['subject_value'])} | {_value(r['other_value'])} | "
                    f"{r['difference']:+.2f} [{r['low']:+.2f}, {r['high']:+.2f}] | {p} | {r['adjusted_p']:.3g} |"
                )
            lines.append("")
    return "\n".join(lines)


def seed0_runs(runs: Path) -> dict[str, Path]:
    """Algorithm -> its seed-0 run folder (``<algo>-s0``); every one of the five must be there."""
    found = {algo: runs / f"{algo}-s0" for algo in ALGOS if (runs / f"{algo}-s0" / "results.json").is_file()}
    missing = [a for a in ALGOS if a not in found]
    if missing:
        raise SystemExit(
            f"{runs} lacks the seed-0 runs of {', '.join(missing)} (benchmarks/lifelong.sh five)"
        )
    return found


def report_runs(runs: Path) -> list[Path]:
    """The run folders the report covers: every seed of the five algorithms (each needs its
    seed-0 run), then the architecture runs."""
    seed0_runs(runs)
    methods = method_runs(runs)
    ordered = [m for m in ALGOS if m in methods] + [m for m in methods if m not in ALGOS]
    return [p for m in ordered for p in methods[m]]


def findings_record(runs: Path, out: Path) -> dict[str, Any]:
    """What ``findings.json`` holds: the paper's row, each finding tested, and the comparisons
    behind them (runs named relative to ``out``)."""
    from libero_bench.analysis.seeds import relative_paths

    seed0_runs(runs)
    methods = method_runs(runs)
    compared = comparisons(methods)
    for result in compared.values():
        relative_paths(result, out)
    entries = findings(compared)
    for finding, entry in zip(FINDINGS, entries, strict=True):
        entry["missing_runs"] = missing_runs(finding, methods)
    return {"alpha": ALPHA, "paper": PAPER, "findings": entries, "comparisons": compared}


def cost_rows(runs: Path) -> list[dict[str, Any]]:
    """What each run cost, from its ``timings.jsonl``: epochs trained (post-prune ones included),
    loss passes (a task's loss before its first epoch, timed as its "epoch 0"), seconds per epoch
    (mean), hours of training (loss passes included) and of evaluation rollouts (two runs shared
    the two cores, one torch thread each)."""
    rows = []
    for folder in sorted(p for p in runs.iterdir() if (p / "timings.jsonl").is_file()):
        lines = [json.loads(x) for x in (folder / "timings.jsonl").read_text().splitlines() if x.strip()]
        timed = [x for x in lines if x.get("what") == "epoch"]
        passes = [x["seconds"] for x in timed if " epoch 0/" in x.get("label", "")]
        epochs = [x["seconds"] for x in timed if " epoch 0/" not in x.get("label", "")]
        evaluate = sum(x["seconds"] for x in lines if x.get("what") == "evaluate")
        rows.append(
            {
                "run": folder.name,
                "epochs": len(epochs),
                "loss_passes": len(passes),
                "seconds_per_epoch": sum(epochs) / len(epochs) if epochs else None,
                "training_hours": (sum(epochs) + sum(passes)) / 3600,
                "evaluation_hours": evaluate / 3600,
            }
        )
    return rows


def cost_markdown(rows: list[dict[str, Any]]) -> str:
    lines = [
        "| run | epochs | loss passes | s per epoch | training h | evaluation h |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        per = "–" if r["seconds_per_epoch"] is None else f"{r['seconds_per_epoch']:.0f}"
        lines.append(
            f"| {r['run']} | {r['epochs']} | {r['loss_passes']} | {per} | {r['training_hours']:.2f} | "
            f"{r['evaluation_hours']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def went_on_from(runs: Path, algo: str, run: Path) -> str | None:
    """The sweep run of ``algo`` that ``run`` went on from (its folder was copied and resumed: its
    ``timings.jsonl`` begins with the sweep run's), or None when it learned every task itself."""
    text = (run / "timings.jsonl").read_text()
    for sweep in sorted(runs.glob(f"sweep-{algo}-*")):
        head = (sweep / "timings.jsonl").read_text() if (sweep / "timings.jsonl").is_file() else ""
        if head and text.startswith(head):
            return sweep.name
    return None


def origins_markdown(runs: Path) -> str:
    """One sentence per swept algorithm's seed-0 run: went on from its sweep run, or learned
    tasks 0 and 1 again itself."""
    lines = []
    for algo in SWEPT:
        run = runs / f"{algo}-s0"
        if not (run / "timings.jsonl").is_file():
            continue
        source = went_on_from(runs, algo, run)
        if source:
            lines.append(
                f"{NAMES[algo]} (`{run.name}`) went on from the sweep run kept (`{source}`): its row counts "
                "tasks 0 and 1 once more (spent once, in that sweep run)."
            )
        else:
            lines.append(
                f"{NAMES[algo]} (`{run.name}`) learned tasks 0 and 1 again itself, with the sweep's kept setting "
                "(the sweep run's checkpoints were not at hand), so its row counts them in full."
            )
    return " ".join(lines) + ("\n" if lines else "")


#: The setting each sweep varies (``benchmarks/lifelong.sh sweep``: runs named ``sweep-<algo>-<value>``).
SWEPT = {"ewc": "penalty_weight", "packnet": "prune_fraction"}


def sweep_rows(runs: Path) -> dict[str, list[dict[str, Any]]]:
    """Per swept algorithm, each sweep run's setting and its FWT, NBT and AUC from held-out starts
    (95% bootstrap intervals), in the order of the setting."""
    from libero_bench.runs.folder import HELDOUT
    from libero_bench.runs.intervals import metric_summary
    from libero_bench.runs.summary import load_run

    out: dict[str, list[dict[str, Any]]] = {}
    for folder in sorted(runs.glob("sweep-*")):
        if not (folder / "results.json").is_file():
            continue
        run = load_run(folder)
        algo = run.config["algo"]
        value = run.config["algo_config"][SWEPT[algo]]
        row = {"run": folder.name, "setting": SWEPT[algo], "value": value, "tasks_done": run.tasks_done}
        row.update(metric_summary([run.draws(HELDOUT)]))
        out.setdefault(algo, []).append(row)
    for rows in out.values():
        rows.sort(key=lambda r: r["value"])
    return out


def pick(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The setting kept: the highest AUC from held-out starts (learning and keeping in one number),
    then the lowest NBT, then the smallest setting (rows come sorted by it); among runs that
    finished both tasks."""
    done = [r for r in rows if r["tasks_done"] == max(x["tasks_done"] for x in rows)]
    return max(done, key=lambda r: (r["auc"]["mean"] or -1.0, -(r["nbt"]["mean"] or 0.0)))


def sweep_markdown(sweeps: dict[str, list[dict[str, Any]]]) -> str:
    lines = [
        "| algorithm | setting | value | FWT (↑) | NBT (↓) | AUC (↑) | kept |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for algo, rows in sweeps.items():
        kept = pick(rows)["run"]
        for r in rows:
            lines.append(
                f"| {NAMES[algo]} | {r['setting']} | {r['value']:g} | {_stat(r['fwt'])} | {_stat(r['nbt'])} | "
                f"{_stat(r['auc'])} | {'kept' if r['run'] == kept else ''} |"
            )
    return (
        "\n".join(lines)
        + "\n\nTasks 0 and 1, held-out starts, 95% bootstrap intervals over rollouts. Kept: the highest AUC, "
        "then the lowest NBT, then the smallest setting. Each sweep run is the start of a run on tasks 0, 1, 2 "
        "stopped after two tasks (`libero-bench run --stop-after 2`); the kept setting is the algorithm's in the "
        "table of the five, whose run goes on from the kept sweep run where its folder is at hand.\n"
    )


def findings_document(runs: Path, report: dict[str, Any], record: dict[str, Any]) -> str:
    """``findings.md``: the table of the five beside the paper's row, each finding's verdict with
    its comparisons, and what the runs cost (``report``: the report's summary of the runs;
    ``record``: :func:`findings_record`)."""
    return (
        "# The lifelong algorithms and architectures on libero_object 0, 1, 2 (quick preset)\n\n"
        + table_markdown(report)
        + "\nIntervals: 95% bootstrap over rollouts (over seeds and rollouts where a method has several). Paper: LIBERO, Table VI, "
        "ResNet-T, LIBERO-Object, three seeds (its MTL row is a success rate).\n\n## The paper's findings\n"
        + findings_markdown(record["findings"])
        + "\n## What the runs cost\n\nTwo runs at a time on two cores, one torch thread each (`timings.jsonl` of each run).\n\n"
        + cost_markdown(cost_rows(runs))
        + "\n"
        + origins_markdown(runs)
    )


def main() -> None:
    from libero_bench.analysis.report import write_report
    from libero_bench.analysis.seeds import seeds_markdown
    from libero_data.runtime.files import write_json, write_text

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, default=RESULTS / "runs", help="folder of the run folders")
    parser.add_argument("--out", type=Path, default=RESULTS, help="where report/ and findings.* go")
    parser.add_argument("--sweep", action="store_true", help="only the sweep's table (sweep.md, sweep.json)")
    parser.add_argument(
        "--pick", choices=sorted(SWEPT), help="print the sweep run kept for this algorithm (its folder name)"
    )
    args = parser.parse_args()
    if args.pick or args.sweep:
        sweeps = sweep_rows(args.runs)
        if args.pick:
            if args.pick not in sweeps:
                raise SystemExit(
                    f"{args.runs} holds no sweep run of {args.pick} (benchmarks/lifelong.sh sweep)"
                )
            print(pick(sweeps[args.pick])["run"])
            return
        write_json(args.out / "sweep.json", sweeps)
        write_text(args.out / "sweep.md", sweep_markdown(sweeps))
        print(sweep_markdown(sweeps))
        return
    report = write_report(report_runs(args.runs), args.out / "report")
    record = findings_record(args.runs, args.out)
    for name, result in record["comparisons"].items():
        write_text(args.out / "compare" / f"{name}.md", seeds_markdown(result))
    write_json(args.out / "findings.json", record)
    text = findings_document(args.runs, report, record)
    write_text(args.out / "findings.md", text)
    print(text)


if __name__ == "__main__":
    main()
