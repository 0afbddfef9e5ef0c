"""``libero-bench report`` and ``replay``: a run's scores with plots, and its stored rollouts."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Any

import typer

from libero_data.cli.common import console, say, user_errors


def print_table(rows: list[list[str]]) -> None:
    """The scores table (one row per method) on the terminal."""
    from rich.table import Table

    from libero_bench.analysis.report import TABLE_HEADER

    table = Table(title_justify="left")
    for column in TABLE_HEADER:
        table.add_column(column)
    for row in rows:
        table.add_row(*row)
    console().print(table)


@user_errors
def report_cmd(
    runs: Annotated[list[Path], typer.Argument(help="Run folders (seeds of one method are averaged).")],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Report folder; default: FIRST_RUN/report.")
    ] = None,
) -> None:
    """FWT / NBT / AUC with 95% intervals, from stored and held-out starts; success matrix, curves and metrics (PNG); JSON."""
    from libero_bench.analysis.report import table_rows, write_report

    folder = out or (runs[0] / "report")
    summary = write_report(runs, folder)
    print_table(table_rows(summary))
    for path in summary["files"]:  # named relative to the report's folder
        say(f"wrote {folder / path}")


@user_errors
def compare_cmd(
    runs: Annotated[
        list[Path],
        typer.Argument(
            help="Two run folders (A, then B); or the seeds of two methods, every run of both (A is the "
            "method of the first one named); or two robustness sweeps' folders."
        ),
    ],
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            "-o",
            help="Folder for compare.json and compare.md (and compare.png for sweeps; default: print only).",
        ),
    ] = None,
) -> None:
    """Is one run better than another? McNemar's exact test on their final checkpoints' paired outcomes.

    Both runs were evaluated from the same starts (stored and held-out); each start pairs run A's
    outcome with run B's, per task and over all tasks, for each kind of start. For runs over the
    same tasks, FWT, NBT and AUC are compared too: the difference A − B with its 95% bootstrap
    interval (paired over starts when both runs were evaluated alike).

    Several seeds of two methods (runs of one algorithm, policy, preset, tasks and settings are
    one method) are paired by seed and start and pooled: McNemar's test on every seed's
    discordant starts; the mean of the seeds' differences with a bootstrap interval over seeds
    and starts and a permutation test stratified by seed.

    Two robustness sweeps (`libero-bench robustness` folders) are compared per kind and level
    from their shared held-out placements: B − A with a paired bootstrap interval, McNemar's test,
    and side-by-side heatmaps.
    """
    from libero_bench.robustness.cells import REPORT
    from libero_data.errors import InputError

    if len(runs) < 2:
        raise InputError("compare needs two run folders (A and B), or the runs of two methods' seeds")
    if len(runs) == 2 and any((run / f"{REPORT}.json").is_file() for run in runs):
        _compare_sweeps(runs[0], runs[1], out)
        return
    if len(runs) > 2:
        _compare_methods(runs, out)
        return
    from libero_bench.analysis.compare import compare_runs, comparison_markdown

    result = compare_runs(runs[0], runs[1])
    _say_lines(result)
    text = comparison_markdown(result)
    if out is not None:
        for side in ("a", "b"):  # the runs named from the comparison's folder, which may move with them
            result[side]["path"] = os.path.relpath(Path(result[side]["path"]).resolve(), out.resolve())
    _write_comparison(result, text, out)


def _say_lines(result: dict[str, Any]) -> None:
    """One line per kind of start on final success, one per metric."""
    from libero_bench.analysis.compare import metric_line, verdict

    for start in ("stored", "heldout"):
        block = result.get(start)
        if block is not None:
            row = block["all"]
            say(
                f"{start} starts, all tasks: A {row['a']['successes']}/{row['n']}, B {row['b']['successes']}/{row['n']}; "
                + verdict(row, "A", "B")
            )
            for name, metric in (block["difference"] or {}).get("metrics", {}).items():
                say(f"{start} starts, {metric_line(name, metric)}")


def _write_comparison(result: dict[str, Any], text: str, out: Path | None) -> None:
    from libero_data.runtime.files import write_json, write_text

    if out is None:
        say(text)
        return
    write_json(out / "compare.json", result)
    write_text(out / "compare.md", text)
    say(f"wrote {out / 'compare.json'} and {out / 'compare.md'}")


def _compare_methods(runs: list[Path], out: Path | None) -> None:
    """Two methods' seeds, paired by seed (libero_bench.analysis.seeds)."""
    import json

    from libero_bench.analysis.seeds import compare_seeds, relative_paths, seeds_markdown
    from libero_bench.runs.summary import load_run
    from libero_data.errors import InputError

    methods: dict[str, list[Path]] = {}
    for path in runs:
        run = load_run(path)
        key = json.dumps([run.group, run.config.get("algo_config")], sort_keys=True)
        methods.setdefault(key, []).append(path)
    if len(methods) != 2:
        raise InputError(
            f"the {len(runs)} runs form {len(methods)} method(s) (algorithm, policy, preset, tasks and "
            "settings); compare takes the seeds of exactly two"
        )
    runs_a, runs_b = methods.values()
    result = compare_seeds(runs_a, runs_b)
    say(f"seeds {', '.join(map(str, result['seeds']))}, paired by seed and start")
    _say_lines(result)
    text = seeds_markdown(result)
    if out is not None:
        relative_paths(result, out)
    _write_comparison(result, text, out)


def _compare_sweeps(sweep_a: Path, sweep_b: Path, out: Path | None) -> None:
    from libero_bench.robustness.paired import compare_sweeps, paired_markdown, write_comparison

    result = compare_sweeps(sweep_a, sweep_b)
    if out is None:
        say(paired_markdown(result))
        return
    paths = write_comparison(result, out)
    say("wrote " + ", ".join(str(p) for p in paths))


@user_errors
def replay_cmd(
    run: Annotated[
        Path, typer.Argument(help="A run folder, or an evaluation folder (libero-bench eval --out).")
    ],
    task: Annotated[str, typer.Option("--task", help="Task name or position in the run or evaluation.")],
    rollout: Annotated[
        int | None,
        typer.Option(
            "--rollout", help="Which of the task's rollouts (in run order); omit to list them.", min=0
        ),
    ] = None,
    rrd: Annotated[Path | None, typer.Option("--rrd", help="Save the Rerun recording here.")] = None,
) -> None:
    """Show a stored evaluation rollout of a run or of an evaluation: list a task's rollouts, or save
    one's Rerun recording."""
    import shutil

    from libero_bench.evaluation.policy_eval import eval_task_rollouts, is_eval_folder
    from libero_bench.runs.folder import RunFolder, task_rollouts

    folder = RunFolder(run)
    if is_eval_folder(run):
        chosen, mine = eval_task_rollouts(run, task)
    else:
        chosen, mine = task_rollouts(folder, task)
    if rollout is None:
        for i, r in enumerate(mine):
            if "phase" in r:
                when = {
                    "learning": f"while learning it, epoch {r['epoch']}",
                    "pruned": "after pruning, before fine-tuning",
                    "after": f"checkpoint kept after task {r['learned_after']}",
                }.get(r["phase"], r["phase"])
            else:  # an evaluation's: from which start
                when = f"{r['start']} start {r['init_index']}" if r.get("init_index", -1) >= 0 else r["start"]
            outcome = "success" if r["success"] else "failure"
            say(f"{i:4d}  {r['key']}  {when}: {outcome} ({r['steps']} steps)")
        return
    record, source = folder.rollout_recording(chosen, mine, rollout)
    outcome = "success" if record["success"] else "failure"
    say(f"{record['key']}: {chosen['language']} — {outcome} after {record['steps']} steps")
    if rrd is None:
        say(f"recording: {source}\nopen it with: rerun {source}")
        return
    rrd.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, rrd)
    say(f"wrote {rrd}")
