"""``libero-data scenes`` and ``contact-sheet``: what procedural generation samples from, and
what a suite's tasks look like."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import console, say, split_list, user_errors


def scenes_cmd() -> None:
    """List the scene layouts and behaviour templates that `generate --procedural` samples from."""
    from rich.table import Table

    from libero_data.scenes.catalogue import load_catalogue
    from libero_data.scenes.templates import TEMPLATES

    cat = load_catalogue()
    table = Table("scene", "kind", "fixtures", "object spots", "from shipped tasks")
    for key, scene in cat.scenes.items():
        fixtures = ", ".join(f.category for f in scene.fixtures) or "—"
        table.add_row(key, scene.kind, fixtures, str(len(scene.boxes)), str(len(scene.sources)))
    console().print(table)
    templates = Table("template", "instruction", "goal", "starts with")
    for t in TEMPLATES.values():
        templates.add_row(t.name, t.pattern, " ∧ ".join(t.goal), " ∧ ".join(t.init) or "—")
    console().print(templates)


@user_errors
def contact_sheet_cmd(
    suite: Annotated[str, typer.Argument(help="Suite name or suite folder (e.g. a procedural suite).")],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help="Image file to write (its suffix says png or jpg); with several kinds, a folder.",
        ),
    ] = Path("contact_sheet.png"),
    count: Annotated[
        int, typer.Option("--count", "-n", help="Without --kind: how many tasks (the first N).", min=1)
    ] = 12,
    size: Annotated[int, typer.Option("--size", help="Frame size in pixels.", min=32, max=512)] = 160,
    seed: Annotated[
        int, typer.Option("--seed", help="Seed of the expert episodes (or of the variants).")
    ] = 0,
    kind: Annotated[
        str | None,
        typer.Option(
            "--kind",
            help="Instead: what each severity level of a variant kind looks like (levels 0-5 of one task), "
            "e.g. camera; comma-separated or 'all' writes one image per kind into the folder --out "
            "(cards/robustness/ holds every kind's: libero_object --kind all --format jpg --out cards/robustness).",
        ),
    ] = None,
    task: Annotated[
        int, typer.Option("--task", help="With --kind: the task's index in the suite.", min=0)
    ] = 0,
    image_format: Annotated[
        str,
        typer.Option(
            "--format",
            help="With --kind, where --out is a folder (several kinds): the images' format, png or jpg "
            "(otherwise --out's suffix decides).",
        ),
    ] = "png",
) -> None:
    """An image grid: first and last agentview frame of one expert episode per task, with its instruction.

    With --kind: the source task and each level 1-5 of a variant kind side by side, agentview over
    eye-in-hand, with what was drawn for each level.
    """
    from libero_data.procedural.contact_sheet import contact_sheet
    from libero_data.tasks import get_suite

    if kind is not None:
        if image_format not in ("png", "jpg"):
            from libero_data.errors import InputError

            raise InputError(f"--format must be png or jpg, got {image_format!r}", field="format")
        _kind_sheets(suite, kind, task, out, size, seed, image_format)
        return
    tasks = list(get_suite(suite).tasks[:count])
    with console().status(f"running the expert on {len(tasks)} task(s)"):
        path = contact_sheet(tasks, out, size=size, seed=seed)
    say(f"wrote {path}")


def _kind_sheets(
    suite: str, kinds: str, index: int, out: Path, size: int, seed: int, image_format: str
) -> None:
    from libero_data.errors import InputError
    from libero_data.perturb.levels import KINDS
    from libero_data.procedural.kind_sheet import kind_sheet
    from libero_data.tasks import get_suite

    chosen = list(KINDS) if kinds == "all" else split_list(kinds)
    unknown = [k for k in chosen if k not in KINDS]
    if unknown:
        raise InputError(
            f"--kind: unknown kind(s) {', '.join(unknown)}; choose among {', '.join(KINDS)} or all"
        )
    tasks = get_suite(suite).tasks
    if index >= len(tasks):
        raise InputError(f"--task {index}: suite {suite} has {len(tasks)} tasks")
    for i, k in enumerate(chosen, 1):
        with console().status(f"{k} ({i}/{len(chosen)}): rendering levels 0-5"):
            target = out / f"{k}.{image_format}" if len(chosen) > 1 or out.is_dir() else out
            path = kind_sheet(tasks[index], k, target, size=size, seed=seed)
        say(f"wrote {path}")
