"""``libero-data``: LIBERO tasks, scenes and demonstration datasets from the command line.

Bad input (unknown task, malformed BDDL, bad flag) prints one sentence and exits with 2.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer
from rich.console import Console

from libero_data.bddl import BDDLError
from libero_data.tasks import TaskLookupError

app = typer.Typer(
    name="libero-data",
    help="LIBERO tasks, scenes and demonstration datasets (LeRobot v3 format).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
F = TypeVar("F", bound=Callable[..., Any])


def _console(stderr: bool = False) -> Console:
    # Wide tables when piped, so names and instructions are not wrapped mid-word.
    return Console(stderr=stderr, width=None if sys.stdout.isatty() else 240, highlight=False)


def fail(message: str, code: int = 2) -> typer.Exit:
    _console(stderr=True).print(f"error: {message}", markup=False, soft_wrap=True)
    return typer.Exit(code)


def user_errors[F: Callable[..., Any]](fn: F) -> F:
    """Turn expected failures into one sentence on stderr and exit code 2."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except (BDDLError, TaskLookupError, FileNotFoundError, NotADirectoryError, ValueError) as exc:
            raise fail(str(exc)) from None
        except KeyboardInterrupt:
            raise fail("interrupted", code=130) from None

    return wrapper  # type: ignore[return-value]


@app.command("tasks")
@user_errors
def tasks_cmd(
    suite: Annotated[
        str | None,
        typer.Option(
            "--suite",
            "-s",
            help="Suite name (libero_spatial, libero_object, libero_goal, libero_10, libero_90, libero_100) or a suite folder; default: the five suites.",
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON lines instead of a table.")] = False,
) -> None:
    """List tasks: index, name, language instruction and goal."""
    import json

    from rich.table import Table

    from libero_data.tasks import SUITE_NAMES, get_suite

    suites = [get_suite(suite)] if suite else [get_suite(n) for n in SUITE_NAMES[:5]]
    console = _console()
    for s in suites:
        if as_json:
            for t in s.tasks:
                row = {
                    "suite": s.name,
                    "index": t.index,
                    "name": t.name,
                    "language": t.language,
                    "goal": t.goal_text,
                }
                print(json.dumps(row))
            continue
        table = Table(title=f"{s.name} ({len(s.tasks)} tasks)", title_justify="left")
        for column in ("index", "name", "language", "goal"):
            table.add_column(column, overflow="fold")
        for t in s.tasks:
            table.add_row(str(t.index), t.name, t.language, t.goal_text)
        console.print(table)


@app.command("show")
@user_errors
def show_cmd(
    task: Annotated[
        str,
        typer.Argument(help="Task as suite/index (libero_goal/0), suite/name, task name, or a .bddl file."),
    ],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="PNG to write; default: <task name>.png.")
    ] = None,
    size: Annotated[
        int, typer.Option("--size", help="Image size in pixels per camera.", min=16, max=2048)
    ] = 256,
    init: Annotated[int, typer.Option("--init", help="Which stored init state to show.", min=0)] = 0,
    seed: Annotated[
        int,
        typer.Option(
            "--seed", help="Seed for fixture placement (and objects, for BDDL files without init states)."
        ),
    ] = 0,
    renderer: Annotated[
        str | None,
        typer.Option("--renderer", help="egl or osmesa; default: $MUJOCO_GL, else the first available."),
    ] = None,
    bddl: Annotated[bool, typer.Option("--bddl/--no-bddl", help="Print the task's BDDL.")] = True,
) -> None:
    """Render a task's initial scene (agentview and eye-in-hand side by side) and print its BDDL."""
    from libero_data.scene import render_initial_scene
    from libero_data.tasks import get_task

    resolved = get_task(task)
    target = out or Path(f"{resolved.name}.png")
    console = _console()
    with console.status("building the scene (first time: ~10 s)"):
        path = render_initial_scene(resolved, target, size=size, init=init, seed=seed, renderer=renderer)
    if bddl:
        console.print(resolved.bddl_path.read_text(), markup=False)
    console.print(f"task: {resolved.id}  {resolved.language}", markup=False)
    console.print(f"wrote {path} (agentview | eye-in-hand, {size}x{size} each)", markup=False)


@app.command("generate")
@user_errors
def generate_cmd(
    out: Annotated[
        Path,
        typer.Option("--out", "-o", help="Dataset folder to create (or to continue, after an interruption)."),
    ],
    suite: Annotated[
        str | None,
        typer.Option(
            "--suite", "-s", help="Suite name (libero_object, ...) or a suite folder; default libero_object."
        ),
    ] = None,
    tasks: Annotated[
        list[str] | None,
        typer.Option(
            "--tasks",
            "-t",
            help="Task indices or names within the suite (repeat or comma-separate); default: all.",
        ),
    ] = None,
    procedural: Annotated[
        int | None,
        typer.Option(
            "--procedural",
            help="Sample this many new tasks (seeded by --seed), keep those the expert solves from at least "
            "half of their sampled initial states, and write them with their dataset into --out.",
            min=1,
        ),
    ] = None,
    scene: Annotated[
        list[str] | None,
        typer.Option(
            "--scene", help="With --procedural: scene layouts to sample from (see `libero-data scenes`)."
        ),
    ] = None,
    template: Annotated[
        list[str] | None,
        typer.Option(
            "--template",
            help="With --procedural: behaviour templates to sample from (see `libero-data scenes`).",
        ),
    ] = None,
    tasks_only: Annotated[
        bool,
        typer.Option(
            "--tasks-only",
            help="With --procedural/--variants-of: stop once the tasks are sampled, checked and written (no dataset).",
        ),
    ] = False,
    variants_of: Annotated[
        str | None,
        typer.Option(
            "--variants-of",
            help="Make robustness variants of this suite's tasks (--tasks to choose some), each proven "
            "feasible with the expert, with their dataset, into --out.",
        ),
    ] = None,
    kinds: Annotated[
        list[str] | None,
        typer.Option(
            "--kinds", help="With --variants-of: layout, distractors, swap, language (default: all)."
        ),
    ] = None,
    episodes_per_task: Annotated[
        int,
        typer.Option(
            "--episodes-per-task",
            "-n",
            help="Successful episodes to keep per task; the first 50 start from LIBERO's stored init states.",
            min=1,
        ),
    ] = 50,
    image_size: Annotated[
        int, typer.Option("--image-size", help="Camera image size in pixels (square).", min=32, max=512)
    ] = 128,
    workers: Annotated[
        int,
        typer.Option("--workers", "-w", help="Parallel worker processes (simulation and rendering).", min=1),
    ] = 1,
    seed: Annotated[
        int, typer.Option("--seed", help="Seed of everything random; same seed, same dataset.")
    ] = 0,
    max_attempts: Annotated[
        int,
        typer.Option(
            "--max-attempts", help="Expert attempts per episode before the episode is given up.", min=1
        ),
    ] = 8,
    repo_id: Annotated[
        str | None,
        typer.Option("--repo-id", help="Dataset id recorded in the metadata; default libero-data/<suite>."),
    ] = None,
    publish_every: Annotated[
        float,
        typer.Option(
            "--publish-every",
            help="Seconds at least between snapshots of the growing dataset in --out (longer once "
            "a snapshot of a big dataset takes time: publishing is kept under 5% of the run).",
            min=0.0,
        ),
    ] = 60.0,
    executor: Annotated[
        str,
        typer.Option(
            "--executor",
            help="Where episodes run: 'local' (--workers processes here) or 'ray' (Ray tasks; same dataset).",
        ),
    ] = "local",
    ray_address: Annotated[
        str | None,
        typer.Option(
            "--ray-address",
            help="Ray cluster to join (e.g. ray://head:10001 or auto); default: start Ray here with --workers CPUs.",
        ),
    ] = None,
) -> None:
    """Generate scripted demonstrations as a LeRobot v3 dataset, with MCAP logs and a dataset card.

    Episodes are searched without cameras and only kept episodes are rendered. Interrupt at any time (even with kill -9) and run the same command again: finished episodes are kept.
    """
    import os
    import shlex
    import time

    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from libero_data.pipeline.generate import generate, resolve_request

    os.environ.setdefault("SVT_LOG", "1")  # the AV1 encoder's banner, once per video
    from libero_data.pipeline.memory import limit_malloc_arenas
    from libero_data.pipeline.ray_runtime import executor_problem

    limit_malloc_arenas()  # with --workers 1 this process renders and writes every episode

    problem = executor_problem(executor, ray_address)
    if problem is not None:
        raise typer.BadParameter(problem[1], param_hint=problem[0])
    task_refs = [part for item in (tasks or []) for part in item.split(",") if part]
    if procedural is not None and variants_of is not None:
        raise typer.BadParameter("choose --procedural or --variants-of, not both")
    if procedural is not None:
        if suite is not None or task_refs:
            raise typer.BadParameter("--procedural makes its own suite; leave out --suite and --tasks")
        suite = str(_procedural_suite(out, procedural, seed, scene, template, workers))
        task_refs = []
    elif variants_of is not None:
        if suite is not None:
            raise typer.BadParameter("--variants-of makes its own suite; leave out --suite")
        suite = str(_procedural_suite(out, 0, seed, None, None, workers, variants_of, kinds, task_refs))
        task_refs = []
    elif scene or template or kinds or tasks_only:
        raise typer.BadParameter(
            "--scene/--template need --procedural, --kinds needs --variants-of, --tasks-only needs either"
        )
    if tasks_only:
        _console().print(
            f"tasks written to {out}; `libero-data tasks --suite {out}` lists them", markup=False
        )
        return
    suite = suite or "libero_object"
    request = resolve_request(
        suite,
        task_refs or None,
        episodes_per_task=episodes_per_task,
        image_size=image_size,
        seed=seed,
        max_attempts=max_attempts,
        repo_id=repo_id,
    )
    command = "libero-data generate " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    console = _console()
    console.print(
        f"generating {len(request.tasks)} task(s) × {request.episodes_per_task} episode(s) of {suite} into {out} "
        + (f"on Ray ({ray_address})" if executor == "ray" and ray_address else f"with {workers} worker(s)")
        + (" via Ray" if executor == "ray" and not ray_address else ""),
        markup=False,
    )
    columns = [
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn(
            "failed {task.fields[failed]} · attempts {task.fields[attempts]} · published {task.fields[published]}"
        ),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
    ]
    start = time.monotonic()
    with Progress(*columns, console=_console(stderr=True), transient=False) as bar:
        job = bar.add_task(
            "episodes",
            total=len(request.tasks) * request.episodes_per_task,
            failed=0,
            attempts=0,
            published=0,
        )

        def show(p: Any) -> None:
            bar.update(
                job, completed=p.done + p.failed, failed=p.failed, attempts=p.attempts, published=p.published
            )

        try:
            result = generate(
                request,
                out,
                workers=workers,
                on_progress=show,
                command=command,
                publish_every=publish_every,
                executor=executor,
                ray_address=ray_address,
            )
        except KeyboardInterrupt:
            raise fail(
                f"interrupted; finished episodes are kept in {out}, run the same command to continue",
                code=130,
            ) from None
    minutes = (time.monotonic() - start) / 60
    console.print(
        f"done: {result.published} episodes in {out} ({result.failed} given up after {request.max_attempts} attempts; "
        f"{minutes:.1f} min)",
        markup=False,
    )
    console.print("load it with:", markup=False)
    console.print(f'  datasets.load_dataset("{out}", split="train")', markup=False)
    console.print(f'  LeRobotDataset("{request.repo_id}", root="{out}")', markup=False)


def _procedural_suite(
    out: Path,
    n: int,
    seed: int,
    scenes: list[str] | None,
    templates: list[str] | None,
    workers: int,
    variants_of: str | None = None,
    kinds: list[str] | None = None,
    tasks: list[str] | None = None,
) -> Path:
    """Sample (or derive variants) and check tasks into ``out`` (``libero_data.procedural.suite``)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from libero_data.procedural.suite import ProceduralSettings, make_suite
    from libero_data.procedural.variants import KINDS

    split = lambda items: tuple(p for item in (items or []) for p in item.split(",") if p)  # noqa: E731
    if variants_of is not None:
        from libero_data.tasks import get_suite

        source = get_suite(variants_of)
        chosen_kinds = split(kinds) or KINDS
        bad = [k for k in chosen_kinds if k not in KINDS]
        if bad:
            raise ValueError(f"unknown variant kind {bad[0]!r}; known: {', '.join(KINDS)}")
        chosen = tuple(str(source.task(t).index) for t in tasks or [])
        n = (len(chosen) or len(source.tasks)) * len(chosen_kinds)
        settings = ProceduralSettings(
            n=n, seed=seed, variants_of=variants_of, kinds=tuple(chosen_kinds), tasks=chosen
        )
    else:
        settings = ProceduralSettings(n=n, seed=seed, scenes=split(scenes), templates=split(templates))
    kept = 0
    columns = [
        TextColumn("tasks"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("kept {task.fields[kept]} · {task.fields[last]}"),
        TimeElapsedColumn(),
    ]
    with Progress(*columns, console=_console(stderr=True)) as bar:
        job = bar.add_task("tasks", total=n, kept=0, last="")

        def seen(v: Any) -> None:
            nonlocal kept
            kept += v.kept
            bar.update(job, advance=1, kept=kept, last=(v.language or v.reason)[:60])

        try:
            verdicts = make_suite(out, settings, workers=workers, on_verdict=seen)
        except KeyboardInterrupt:
            raise fail(
                f"interrupted; checked tasks are kept in {out}, run the same command to continue", code=130
            ) from None
    kept_n = sum(v.kept for v in verdicts)
    _console().print(
        f"procedural: {kept_n} of {n} sampled tasks kept (report: {out / 'procedural_report.md'})",
        markup=False,
    )
    if kept_n == 0:
        raise fail(f"none of the {n} sampled tasks was kept; see {out / 'procedural_report.md'}")
    return out


@app.command("scenes")
def scenes_cmd() -> None:
    """List the scene layouts and behaviour templates that `generate --procedural` samples from."""
    from rich.table import Table

    from libero_data.procedural.catalogue import load_catalogue
    from libero_data.procedural.templates import TEMPLATES

    cat = load_catalogue()
    table = Table("scene", "kind", "fixtures", "object spots", "from shipped tasks")
    for key, scene in cat.scenes.items():
        fixtures = ", ".join(f.category for f in scene.fixtures) or "—"
        table.add_row(key, scene.kind, fixtures, str(len(scene.boxes)), str(len(scene.sources)))
    _console().print(table)
    templates = Table("template", "instruction", "goal", "starts with")
    for t in TEMPLATES.values():
        templates.add_row(t.name, t.pattern, " ∧ ".join(t.goal), " ∧ ".join(t.init) or "—")
    _console().print(templates)


@app.command("contact-sheet")
@user_errors
def contact_sheet_cmd(
    suite: Annotated[str, typer.Argument(help="Suite name or suite folder (e.g. a procedural suite).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="PNG file to write.")] = Path("contact_sheet.png"),
    count: Annotated[int, typer.Option("--count", "-n", help="How many tasks (the first N).", min=1)] = 12,
    size: Annotated[int, typer.Option("--size", help="Frame size in pixels.", min=32, max=512)] = 160,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the expert episodes.")] = 0,
) -> None:
    """A PNG grid: first and last agentview frame of one expert episode per task, with its instruction."""
    from libero_data.procedural.contact_sheet import contact_sheet
    from libero_data.tasks import get_suite

    tasks = list(get_suite(suite).tasks[:count])
    with _console().status(f"running the expert on {len(tasks)} task(s)"):
        path = contact_sheet(tasks, out, size=size, seed=seed)
    _console().print(f"wrote {path}", markup=False)


@app.command("validate")
@user_errors
def validate_cmd(
    dataset: Annotated[Path, typer.Argument(help="Dataset folder.")],
    resimulate: Annotated[
        int,
        typer.Option(
            "--resimulate",
            help="Re-simulate this many episodes (spread over the dataset) and check they still succeed.",
            min=0,
        ),
    ] = 0,
    tolerance: Annotated[
        float,
        typer.Option(
            "--tolerance",
            help=(
                "For episodes made on another machine or by other libero-data code: how far (m or rad) "
                "re-simulated joint and object positions may depart from the stored ones. Episodes made "
                "on this machine's numeric path are always checked exactly. Default: exact everywhere."
            ),
            min=0.0,
        ),
    ] = 0.0,
) -> None:
    """Check a dataset: metadata against files, frame counts of parquet and video, MCAP logs; optionally re-simulate.

    A re-simulation is exact on a machine whose numeric path (libero_data.numerics) is the one
    that made the episode. Made elsewhere, a replay can depart in the last bits and contact can
    grow them: the report then says from which frame, how far, and what differs between the
    two machines, and --tolerance decides.
    """
    from libero_data.pipeline.validate import validate

    console = _console()
    with console.status("validating") as status:
        report = validate(
            dataset, resimulate=resimulate, tolerance=tolerance, on_step=lambda s: status.update(s)
        )
    console.print(f"{dataset}: {report.episodes} episodes, {report.frames} frames", markup=False)
    if resimulate:
        console.print(
            f"re-simulated {report.resimulated} episode(s): {report.resimulated_ok} reached their goal",
            markup=False,
        )
    for note in report.notes:
        console.print(f"note: {note}", markup=False, soft_wrap=True)
    if report.ok:
        console.print("ok: no inconsistency found", markup=False)
        return
    for issue in report.issues or []:
        _console(stderr=True).print(f"problem: {issue}", markup=False, soft_wrap=True)
    if report.departed_elsewhere:
        _console(stderr=True).print(
            f"{report.departed_elsewhere} episode(s) were made on another numeric path or by other code, where "
            "replays can depart in the last bits (README, Reproducibility); --tolerance sets how far they may.",
            markup=False,
            soft_wrap=True,
        )
    raise fail(f"{len(report.issues or [])} problem(s) found in {dataset}", code=1)


@app.command("replay")
@user_errors
def replay_cmd(
    dataset: Annotated[Path, typer.Argument(help="Dataset folder.")],
    episode: Annotated[int, typer.Option("--episode", "-e", help="Episode index.", min=0)] = 0,
    rrd: Annotated[
        Path | None,
        typer.Option(
            "--rrd", help="Write the Rerun recording here; default: episode_<K>.rrd in the current folder."
        ),
    ] = None,
) -> None:
    """Save a stored episode as a Rerun recording (both cameras, state, action, language)."""
    from libero_data.pipeline.replay import episode_to_rrd

    if not (dataset / "meta" / "info.json").is_file():
        raise FileNotFoundError(f"{dataset} is not a dataset folder (meta/info.json is missing)")
    target = rrd or Path(f"episode_{episode}.rrd")
    with _console().status("writing the recording"):
        path = episode_to_rrd(dataset, episode, target)
    _console().print(f"wrote {path}; open it with: rerun {path}", markup=False)


@app.command("expert-report")
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
            help="Task indices or names within the suite (one --suite only; repeat or comma-separate).",
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
) -> None:
    """Measure the scripted expert's success rate per task over its stored init states.

    Every finished task is journalled in OUT/expert_report.jsonl; stop at any time and run
    the same command again to measure only the tasks still missing. The tables
    (expert_report.csv / .md) are rewritten after every task.
    """
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from libero_data.cards.expert_table import verdict
    from libero_data.experts.expert import ExpertConfig
    from libero_data.experts.report import (
        ReportJournal,
        expert_fingerprint,
        run_report,
        summarise,
        write_report,
    )
    from libero_data.numerics import machine_fingerprint
    from libero_data.pipeline.generate import versions
    from libero_data.pipeline.provenance import machine_line
    from libero_data.tasks import SUITE_NAMES, get_suite

    names = [n for item in (suite or list(SUITE_NAMES[:5])) for n in item.split(",") if n]
    if tasks:
        if len(names) != 1:
            raise typer.BadParameter("--tasks needs exactly one --suite", param_hint="--tasks")
        chosen = get_suite(names[0])
        refs = list(dict.fromkeys(chosen.task(t).id for item in tasks for t in item.split(",") if t))
    else:
        refs = [t.id for name in names for t in get_suite(name).tasks]
    config = ExpertConfig()
    machine = machine_fingerprint()
    settings: dict[str, object] = {
        "inits": inits,
        "seed": seed,
        "expert": expert_fingerprint(),
        "config": repr(config),
        "versions": versions(),
        # Rows measured on another numeric path would not reproduce on one machine.
        "numeric_key": machine["numeric_key"],
    }
    journal = ReportJournal(out, settings, fresh=fresh)
    todo = [r for r in refs if r not in journal.done]

    def rows() -> list:
        return [journal.done[r] for r in refs if r in journal.done]

    def meta() -> dict[str, str]:
        have = rows()
        m = {
            "inits per task": str(inits),
            "seed": str(seed),
            "expert code": str(settings["expert"]),
            "tasks measured": f"{len(have)} of {len(refs)}",
            "episode-minutes": f"{sum(r.seconds_per_episode * r.episodes for r in have) / 60:.0f}",
        }
        m.update({f"version {k}": v for k, v in versions().items()})
        m[f"numeric path {machine['numeric_key']}"] = machine_line(machine)
        return m

    columns = [
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[last]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
    ]
    if len(todo) < len(refs):
        _console(stderr=True).print(
            f"resuming: {len(refs) - len(todo)} of {len(refs)} tasks already measured in {journal.path}",
            markup=False,
        )

    def finished(ref: str, result) -> None:
        journal.add(ref, result)
        write_report(rows(), out, meta=meta())
        bar.update(job, advance=1, last=f"{ref}: {result.successes}/{result.episodes}")

    with Progress(*columns, console=_console(stderr=True)) as bar:
        job = bar.add_task("tasks", total=len(refs), completed=len(refs) - len(todo), last="")
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
    csv_path, md_path = write_report(results, out, meta=meta())
    console = _console()
    for name, s in summarise(results).items():
        console.print(
            f"{name}: {s['rate']:.1%} of {int(s['episodes'])} (95% interval {s['low']:.1%}–{s['high']:.1%}; "
            f"target {s['target']:.0%}: {verdict(s['rate'], s['high'], s['target'])}), "
            f"lowest task {s['lowest_task_rate']:.0%}",
            markup=False,
        )
    console.print(f"wrote {csv_path} and {md_path}", markup=False)


@app.command("card")
@user_errors
def card_cmd(
    suite: Annotated[str, typer.Option("--suite", "-s", help="Suite name.")],
    report: Annotated[
        Path, typer.Option("--expert-report", help="expert_report.csv from `libero-data expert-report`.")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Markdown file to write.")],
    episodes_per_task: Annotated[int, typer.Option("--episodes-per-task", "-n", min=1)] = 50,
    image_size: Annotated[int, typer.Option("--image-size", min=32, max=512)] = 128,
    seed: Annotated[int, typer.Option("--seed")] = 0,
) -> None:
    """Render the dataset card that `generate` would write for a suite, from an expert report."""
    import csv

    from libero_data.pipeline.generate import suite_card

    if not report.is_file():
        raise FileNotFoundError(f"expert report {report} does not exist")
    rates = {}
    with report.open() as f:
        for row in csv.DictReader(f):
            rates[row["name"]] = (int(row["successes"]), int(row["episodes"]))
    text = suite_card(
        suite,
        rates,
        episodes_per_task=episodes_per_task,
        image_size=image_size,
        seed=seed,
        measured_by=_report_settings(report.with_suffix(".jsonl")),
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    _console().print(f"wrote {out}", markup=False)


def _report_settings(journal: Path) -> dict[str, str] | None:
    """Expert code, init states and seed from an expert report's journal header, if it has one."""
    import json

    try:
        settings = json.loads(journal.read_text().split("\n", 1)[0])["settings"]
        found = {
            "expert code": str(settings["expert"]),
            "init states per task": str(settings["inits"]),
            "seed": str(settings["seed"]),
        }
        if "numeric_key" in settings:  # reports since machines were recorded
            found["numeric path"] = str(settings["numeric_key"])
        return found
    except (OSError, ValueError, KeyError, TypeError):
        return None  # no journal beside the table (or not one): the card just says less


def main() -> None:
    from libero_data.numerics import pin

    pin()  # before anything loads NumPy: see libero_data.numerics
    app()


if __name__ == "__main__":
    main()
