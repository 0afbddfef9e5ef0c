"""``libero-bench saliency``: where a run's agentview encoder looks, on demonstrations or rollouts."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import say, split_list, user_errors
from libero_data.errors import InputError


@user_errors
def saliency_cmd(
    run: Annotated[Path, typer.Argument(help="A run folder.")],
    task: Annotated[str, typer.Option("--task", help="Task name or position in the run.")],
    frames: Annotated[
        str | None,
        typer.Option("--frames", help="Comma-separated frame indices; default: 4 spread over the episode."),
    ] = None,
    source: Annotated[
        str, typer.Option("--source", help="demo (the task's first demonstration) or rollout.")
    ] = "demo",
    rollout: Annotated[
        int, typer.Option("--rollout", help="With --source rollout: which of the task's rollouts.", min=0)
    ] = 0,
    after: Annotated[
        str | None,
        typer.Option("--after", help="Use the checkpoint kept after this task; default: after --task."),
    ] = None,
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Output folder; default: RUN/saliency/<task>.")
    ] = None,
) -> None:
    """Perturbation saliency of the agentview encoder: PNG overlays and a Rerun recording."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from libero_bench.analysis.saliency_run import saliency_for_run

    written = saliency_for_run(
        run, task=task, frames=_frame_list(frames), source=source, rollout=rollout, after=after, out=out
    )
    for path in written:
        say(f"wrote {path}")


def _frame_list(text: str | None) -> list[int] | None:
    if not text:
        return None
    try:
        return [int(f) for f in split_list(text)]
    except ValueError:
        raise InputError(f"--frames takes comma-separated frame numbers, got {text!r}") from None
