"""``libero-bench migrate``: run folders of earlier versions brought up to date (pickled
checkpoints to safetensors, the record of their training starts)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import say, user_errors


@user_errors
def migrate_cmd(
    path: Annotated[
        Path,
        typer.Argument(help="A run folder (its checkpoints/*.pt), or one pickled checkpoint or state dict."),
    ],
    out: Annotated[
        Path | None,
        typer.Option(
            "--out", "-o", help="Where one file's safetensors go (default: beside it, .safetensors)."
        ),
    ] = None,
) -> None:
    """Bring an earlier run folder up to date, or convert one pickled checkpoint to safetensors.

    Every other command refuses pickles, because opening one can run code. This one reads them
    with torch's restricted loader (weights_only=True: tensors, numbers, strings, NumPy arrays),
    which refuses a pickle that would run code; still, convert only files you trust. A run
    folder's .pt files are replaced by their .safetensors once those read back; the run then
    resumes, evaluates and serves as before. A run folder from before runs recorded where their
    demonstrations started also gets that record (training_data.json), read from its datasets
    while they are there: it is what held-out evaluation and robustness sweeps of the run need
    once the datasets are gone (a run copied elsewhere, a committed run).
    """
    from libero_bench.runs.migrate import WARNING, migrate

    done = migrate(path, out)
    for step in done:
        verb = "recorded" if step.kind == "training data" else "converted"
        say(f"{verb} {step.source} -> {step.target} ({step.kind})")
    if any(step.kind != "training data" for step in done):
        say(f"note: {WARNING}", stderr=True)
