"""``libero-bench migrate``: pickled checkpoints of earlier versions to safetensors."""

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
    """Convert pickled checkpoints (.pt, from libero-bench before safetensors) to safetensors.

    Every other command refuses pickles, because opening one can run code. This one reads them
    with torch's restricted loader (weights_only=True: tensors, numbers, strings, NumPy arrays),
    which refuses a pickle that would run code; still, convert only files you trust. A run
    folder's .pt files are replaced by their .safetensors once those read back; the run then
    resumes, evaluates and serves as before.
    """
    from libero_bench.runs.migrate import WARNING, migrate

    for done in migrate(path, out):
        say(f"converted {done.source} -> {done.target} ({done.kind})")
    say(f"note: {WARNING}", stderr=True)
