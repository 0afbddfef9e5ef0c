"""``libero-data import``: LIBERO's HDF5 demonstration files (human) as a libero-data dataset."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import (
    ExecutorKind,
    RayAddress,
    RenderQuality,
    Workers,
    say,
    split_list,
    user_errors,
)
from libero_data.cli.generate import Features, GenImageSize, KeepWork, episodes_with_progress
from libero_data.cli.rerender import NewDatasetOut, RenderCameras


@user_errors
def import_cmd(
    files: Annotated[
        list[Path],
        typer.Argument(
            help="LIBERO HDF5 files (one per task, as LIBERO distributes them) or folders of them, all of one suite."
        ),
    ],
    out: NewDatasetOut,
    image_size: GenImageSize = None,
    features: Features = "libero-data",
    cameras: RenderCameras = None,
    render_quality: RenderQuality = "full",
    tolerance: Annotated[
        float,
        typer.Option(
            "--tolerance",
            help="Largest deviation (m or rad) of a joint or object position when each stored state is stepped "
            "with its action and compared with the next; demonstrations beyond it are left out.",
        ),
    ] = 0.01,
    drop_noops: Annotated[
        bool,
        typer.Option(
            "--drop-noops",
            help="Leave out frames whose action neither moves the arm nor changes the gripper (counted per episode "
            "in the card).",
        ),
    ] = False,
    workers: Workers = 1,
    executor: ExecutorKind = "local",
    ray_address: RayAddress = None,
    keep_work: KeepWork = False,
) -> None:
    """Import LIBERO's own (human) demonstrations from its HDF5 files into a LeRobot v3 dataset.

    Each file's task is found from its BDDL; each demonstration's fixtures are placed from its stored model XML,
    its states are checked step by step under this simulator, the stored init state it began from is measured,
    and its frames are rendered again from its states (upright, any size, cameras and naming), with an MCAP log per
    episode and a card. Interrupt at any time and run the same command again: finished episodes are kept.
    """
    import os

    from libero_data.pipeline.importer import plan_import, run_import
    from libero_data.record.features import CAMERAS, PROFILE_IMAGE_SIZE
    from libero_data.runtime.jobs import JobPlacement

    os.environ.setdefault("SVT_LOG", "1")
    JobPlacement(executor, workers, ray_address)  # checked before any work
    size = image_size or PROFILE_IMAGE_SIZE.get(features, 128)
    chosen = tuple(split_list(cameras)) or CAMERAS
    request, by_task = plan_import(  # a file that is not LIBERO's is its sentence alone
        files,
        out,
        image_size=size,
        features=features,
        cameras=chosen,
        render_quality=render_quality,
        tolerance=tolerance,
        drop_noops=drop_noops,
    )
    say(
        f"importing {sum(len(f.demo_keys) for f in by_task.values())} demonstrations of {len(by_task)} "
        f"{request.suite} task(s) at {size}x{size} ({', '.join(chosen)}; {features} names) into {out}"
    )
    command = "libero-data import " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    episodes_with_progress(
        lambda show: run_import(
            request,
            by_task,
            out,
            workers=workers,
            executor=executor,
            ray_address=ray_address,
            on_progress=show,
            on_step=say,
            command=command,
            keep_work=keep_work,
        ),
        request,
        out,
    )
