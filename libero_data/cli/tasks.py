"""``libero-data tasks`` and ``libero-data show``: the task list, and one task's initial scene."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import (
    PlusAssetsOption,
    PlusFilesOption,
    ViewRenderQuality,
    console,
    say,
    use_plus,
    user_errors,
)


@user_errors
def tasks_cmd(
    suite: Annotated[
        str | None,
        typer.Option(
            "--suite",
            "-s",
            help="Suite name (libero_spatial, libero_object, libero_goal, libero_10, libero_90, libero_100; a LIBERO-PRO suite: libero_goal_swap, libero_object_lan, ..., --suite pro lists them; with --plus a LIBERO-Plus suite, plus/libero_object, ...) or a suite folder; default: the five suites (with --plus: LIBERO-Plus's four, counted by category).",
        ),
    ] = None,
    as_json: Annotated[
        bool,
        typer.Option(
            "--json",
            help="Print JSON lines instead of a table (the LIBERO-Plus counts by category stay a table).",
        ),
    ] = False,
    plus: PlusFilesOption = None,
    plus_assets: PlusAssetsOption = None,
    category: Annotated[
        str | None,
        typer.Option(
            "--category",
            help="With a LIBERO-Plus suite (--suite plus/...): only the tasks of this category (camera, robot, language, light, "
            "background, noise, layout).",
        ),
    ] = None,
) -> None:
    """List tasks: index, name, language instruction and goal (a LIBERO-Plus task: its category and the
    prompt their benchmark builds from its file name)."""
    import json

    from rich.table import Table

    from libero_data.tasks import SUITE_NAMES, get_suite, pro_suite_names
    from libero_data.tasks.plus import plus_base

    use_plus(plus, plus_assets)
    if suite == "pro":
        for name in pro_suite_names():
            print(name)
        return
    if (plus is not None and suite is None) or (suite is not None and plus_base(suite) is not None):
        _plus_tasks(suite, category, as_json)
        return
    suites = [get_suite(suite)] if suite else [get_suite(n) for n in SUITE_NAMES[:5]]
    out = console()
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
        out.print(table)


def _plus_tasks(suite: str | None, category: str | None, as_json: bool) -> None:
    """LIBERO-Plus's suites counted by category, or one suite's tasks."""
    import json
    from collections import Counter

    from rich.table import Table

    from libero_data.errors import InputError
    from libero_data.tasks import get_suite
    from libero_data.tasks.plus import BASES, CATEGORIES, PREFIX
    from libero_data.tasks.plus_cache import plus_infos

    if category is not None and category not in CATEGORIES:
        raise InputError(
            f"unknown LIBERO-Plus category {category!r}; choose from {', '.join(CATEGORIES)}",
            field="category",
        )
    out = console()
    if suite is None:
        table = Table(title="LIBERO-Plus (tasks per category)", title_justify="left")
        for column in ("suite", *CATEGORIES, "total", "runs here"):
            table.add_column(column, justify="left" if column == "suite" else "right")
        for base in BASES:
            counts = Counter(i.category for i in plus_infos(PREFIX + base))
            runs = sum(1 for t in get_suite(PREFIX + base).tasks if not t.missing)
            table.add_row(
                PREFIX + base, *(str(counts[c]) for c in CATEGORIES), str(sum(counts.values())), str(runs)
            )
        out.print(table)
        say(
            "'runs here': without their assets (--plus-assets) the others are refused, naming the file they need"
        )
        return
    tasks = get_suite(suite).tasks
    rows = [(t, i) for t, i in zip(tasks, plus_infos(suite), strict=True) if category in (None, i.category)]
    if as_json:
        for t, i in rows:
            print(
                json.dumps(
                    {
                        "suite": t.suite,
                        "index": t.index,
                        "name": t.name,
                        "category": i.category,
                        "language": t.language,
                        "their_prompt": i.their_prompt,
                        "problem": i.problem_class,
                        "missing": t.missing,
                    }
                )
            )
        return
    table = Table(title=f"{suite} ({len(rows)} tasks)", title_justify="left")
    for column in ("index", "category", "name", "language"):
        table.add_column(column, overflow="fold")
    for t, i in rows:
        table.add_row(str(t.index), i.category, t.name, t.language)
    out.print(table)


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
    render_quality: ViewRenderQuality = "full",
    plus: PlusFilesOption = None,
    plus_assets: PlusAssetsOption = None,
) -> None:
    """Render a task's initial scene (agentview and eye-in-hand side by side) and print its BDDL."""
    from libero_data.initial_scene import render_initial_scene
    from libero_data.tasks import get_task

    use_plus(plus, plus_assets)
    resolved = get_task(task)
    target = out or Path(f"{resolved.name}.png")
    with console().status("building the scene (first time: ~10 s)"):
        path = render_initial_scene(
            resolved,
            target,
            size=size,
            init=init,
            seed=seed,
            renderer=renderer,
            render_quality=render_quality,
        )
    if bddl:
        say(resolved.bddl_path.read_text())
    say(f"task: {resolved.id}  {resolved.language}")
    say(f"wrote {path} (agentview | eye-in-hand, {size}x{size} each)")
