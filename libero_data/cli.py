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
        except (BDDLError, TaskLookupError, FileNotFoundError, ValueError) as exc:
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


def main() -> None:
    app()


if __name__ == "__main__":
    main()
