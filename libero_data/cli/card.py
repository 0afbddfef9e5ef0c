"""``libero-data card``: the card ``generate`` would write for a suite, from an expert report."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import say, user_errors


@user_errors
def card_cmd(
    suite: Annotated[str, typer.Option("--suite", "-s", help="Suite name.")],
    report: Annotated[
        Path, typer.Option("--expert-report", help="expert_report.csv from `libero-data expert-report`.")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Markdown file to write.")],
    episodes_per_task: Annotated[
        int, typer.Option("--episodes-per-task", "-n", min=1, help="Episodes per task the card states.")
    ] = 50,
    image_size: Annotated[
        int, typer.Option("--image-size", min=32, max=512, help="Image size the card states, in pixels.")
    ] = 128,
    seed: Annotated[int, typer.Option("--seed", help="Generation seed the card states.")] = 0,
) -> None:
    """Render the dataset card that `generate` would write for a suite, from an expert report.

    Where the report's journal (expert_report.jsonl) is beside its table, the card also shows the
    episodes' lengths against each task's standard step limit, with a plot beside it (card.md: card_lengths.png).
    """
    from libero_data.cards.expert_files import read_measured, report_settings
    from libero_data.pipeline.describe import suite_card
    from libero_data.runtime.files import write_bytes, write_text

    image = out.with_name(f"{out.stem}_lengths.png")
    text, plot = suite_card(
        suite,
        read_measured(report),
        episodes_per_task=episodes_per_task,
        image_size=image_size,
        seed=seed,
        measured_by=report_settings(report.with_suffix(".jsonl")),
        lengths_image=image.name,
    )
    write_text(out, text)
    if plot is not None:
        write_bytes(image, plot)
        say(f"wrote {out} and {image}")
    else:
        say(f"wrote {out}")
