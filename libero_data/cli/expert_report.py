"""``libero-data expert-report``: the scripted expert's success rate per task, resumable."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from libero_data.cli.common import (
    PlusAssetsOption,
    PlusFilesOption,
    console,
    progress,
    say,
    split_list,
    use_plus,
    user_errors,
)


@user_errors
def expert_report_cmd(
    suite: Annotated[
        list[str] | None, typer.Option("--suite", "-s", help="Suite(s) to measure; default: the five suites.")
    ] = None,
    tasks: Annotated[
        list[str] | None,
        typer.Option(
            "--tasks",
            "-t",
            help="Task indices or names within the suite (one --suite only), or without --suite whole task "
            "references (libero_goal/3, plus/libero_object/248); repeat or comma-separate.",
        ),
    ] = None,
    inits: Annotated[
        int, typer.Option("--inits", help="Stored init states per task (the first N).", min=1, max=50)
    ] = 50,
    workers: Annotated[int, typer.Option("--workers", "-w", help="Parallel worker processes.", min=1)] = 1,
    seed: Annotated[
        int, typer.Option("--seed", help="Seed of the expert's styles and fixture placement.")
    ] = 0,
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Folder for expert_report.csv and expert_report.md.")
    ] = Path("."),
    fresh: Annotated[
        bool,
        typer.Option(
            "--fresh",
            help="Start over instead of resuming the report already in --out (expert_report.jsonl).",
        ),
    ] = False,
    tables_only: Annotated[
        bool,
        typer.Option(
            "--tables-only",
            help="Measure nothing: write the tables and the length plot again from OUT/expert_report.jsonl "
            "alone (after the tables' code changed).",
        ),
    ] = False,
    plus: PlusFilesOption = None,
    plus_assets: PlusAssetsOption = None,
) -> None:
    """Measure the scripted expert's success rate per task over its stored init states.

    Every finished task is journalled in OUT/expert_report.jsonl; stop at any time and run
    the same command again to measure only the tasks still missing. The tables
    (expert_report.csv / .md, with success within each task's standard step limit beside success
    at all, and the length plot expert_lengths.png) are rewritten after every task.
    """
    from libero_data.cards.expert_files import report_meta, rewrite_report
    from libero_data.cards.expert_table import write_report
    from libero_data.experts.expert import ExpertConfig
    from libero_data.experts.report import ReportJournal, read_report, run_report
    from libero_data.numerics import machine_fingerprint
    from libero_data.provenance import machine_line
    from libero_data.tasks import SUITE_NAMES

    if tables_only:
        csv_path, md_path = rewrite_report(out)
        _print_summary(list(read_report(out / ReportJournal.NAME)[1].values()))
        say(f"wrote {csv_path} and {md_path} from {out / ReportJournal.NAME}")
        return
    use_plus(plus, plus_assets)
    refs = _task_refs(split_list(suite), split_list(tasks), list(SUITE_NAMES[:5]))
    config = ExpertConfig()
    settings = _settings(inits, seed, config)
    journal = ReportJournal(out, settings, fresh=fresh, machine=machine_line(machine_fingerprint()))
    todo = [r for r in refs if r not in journal.done]
    if len(todo) < len(refs):
        say(
            f"resuming: {len(refs) - len(todo)} of {len(refs)} tasks already measured in {journal.path}",
            stderr=True,
        )

    def rows() -> list[Any]:  # in the journal's order, as `--tables-only` reads them
        return [result for ref, result in journal.done.items() if ref in set(refs)]

    with progress("last") as bar:
        job = bar.add_task("tasks", total=len(refs), completed=len(refs) - len(todo), last="")

        def finished(ref: str, result: Any) -> None:
            journal.add(ref, result)
            write_report(rows(), out, meta=report_meta(journal.header, rows(), len(refs)))
            bar.update(job, advance=1, last=f"{ref}: {result.successes}/{result.episodes}")

        run_report(
            todo,
            inits,
            seed=seed,
            workers=workers,
            config=config,
            on_task=finished,
            fingerprint=str(settings["expert"]),
        )
    results = rows()
    csv_path, md_path = write_report(results, out, meta=report_meta(journal.header, results, len(refs)))
    _print_summary(results)
    say(f"wrote {csv_path} and {md_path}")


def _print_summary(results: list[Any]) -> None:
    """Per suite: success at all against its target, the lowest task, success within the limit."""
    from libero_data.cards.expert_table import limit_words, summarise, verdict, within_words

    for name, s in summarise(results).items():
        console().print(
            f"{name}: {s['rate']:.1%} of {int(s['episodes'])} (95% interval {s['low']:.1%}–{s['high']:.1%}; "
            + ("" if math.isnan(s["target"]) else f"target {s['target']:.0%}: ")
            + f"{verdict(s['rate'], s['high'], s['target'])}), "
            + f"lowest task {s['lowest_task_rate']:.0%}; "
            + f"within the standard limit ({limit_words(s['limit'], name)}): {within_words(s)}",
            markup=False,
        )


def _task_refs(suites: list[str], tasks: list[str], default: list[str]) -> list[str]:
    from libero_data.tasks import get_suite, get_task

    if tasks and not suites:
        return list(dict.fromkeys(get_task(t).id for t in tasks))
    suites = suites or default
    if tasks:
        if len(suites) != 1:
            raise typer.BadParameter("--tasks needs exactly one --suite", param_hint="--tasks")
        chosen = get_suite(suites[0])
        return list(dict.fromkeys(chosen.task(t).id for t in tasks))
    return [t.id for name in suites for t in get_suite(name).tasks]


def _settings(inits: int, seed: int, config: Any) -> dict[str, object]:
    """What a report's rows depend on (a resumed report must have the same)."""
    from libero_data.numerics import machine_fingerprint
    from libero_data.provenance import expert_code
    from libero_data.runtime.versions import versions

    return {
        "inits": inits,
        "seed": seed,
        "expert": expert_code(),
        "config": repr(config),
        "versions": versions(),
        # Rows measured on another numeric path would not reproduce on one machine.
        "numeric_key": machine_fingerprint()["numeric_key"],
    }
