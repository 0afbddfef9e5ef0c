"""``libero-data validate`` and ``replay``: check a dataset, and look at one of its episodes."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import console, fail, say, user_errors


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

    with console().status("validating") as status:
        report = validate(
            dataset, resimulate=resimulate, tolerance=tolerance, on_step=lambda s: status.update(s)
        )
    say(f"{dataset}: {report.episodes} episodes, {report.frames} frames")
    if resimulate:
        say(f"re-simulated {report.resimulated} episode(s): {report.resimulated_ok} reached their goal")
    for note in report.notes:
        say(f"note: {note}")
    if report.ok:
        say("ok: no inconsistency found")
        return
    for issue in report.issues or []:
        say(f"problem: {issue}", stderr=True)
    if report.departed_elsewhere:
        say(
            f"{report.departed_elsewhere} episode(s) were made on another numeric path or by other code, where "
            "replays can depart in the last bits (docs/reproducibility.md); --tolerance sets how far they may.",
            stderr=True,
        )
    raise fail(f"{len(report.issues or [])} problem(s) found in {dataset}", code=1)


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
    """Save a stored episode as a Rerun recording (the dataset's cameras, state, action, language)."""
    from libero_data.pipeline.replay import episode_to_rrd

    target = rrd or Path(f"episode_{episode}.rrd")
    with console().status("writing the recording"):
        path = episode_to_rrd(dataset, episode, target)
    say(f"wrote {path}; open it with: rerun {path}")
