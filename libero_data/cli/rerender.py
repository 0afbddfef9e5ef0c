"""``libero-data rerender``: a dataset's episodes rendered again at another size, camera set or naming."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import RenderQuality, Workers, say, split_list, user_errors
from libero_data.cli.generate import Features, GenImageSize, KeepWork, episodes_with_progress

#: The cameras a command renders a dataset's frames with (rerender, import).
RenderCameras = Annotated[
    list[str] | None,
    typer.Option(
        "--cameras", help="Cameras to render: agentview, eye_in_hand (comma-separate); default both."
    ),
]
#: The dataset folder a command writes (rerender, import).
NewDatasetOut = Annotated[
    Path, typer.Option("--out", "-o", help="The new dataset folder (an interrupted run continues).")
]


@user_errors
def rerender_cmd(
    dataset: Annotated[Path, typer.Argument(help="A finished libero-data dataset.")],
    out: NewDatasetOut,
    image_size: GenImageSize = None,
    features: Features = "libero-data",
    cameras: RenderCameras = None,
    render_quality: RenderQuality = "full",
    workers: Workers = 1,
    keep_work: KeepWork = False,
) -> None:
    """Render a dataset's episodes again from their stored MuJoCo states: the same episodes, actions and
    states at another image size, camera set or feature naming (e.g. 256x256 for LeRobot's LIBERO policies).
    """
    import os

    from libero_data.pipeline.rerender import check_rerender_output, rerender, rerender_request
    from libero_data.record.features import CAMERAS, PROFILE_IMAGE_SIZE

    os.environ.setdefault("SVT_LOG", "1")
    size = image_size or PROFILE_IMAGE_SIZE.get(features, 128)
    chosen = tuple(split_list(cameras)) or CAMERAS
    request = rerender_request(
        dataset.resolve(), image_size=size, features=features, cameras=chosen, render_quality=render_quality
    )
    command = "libero-data rerender " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    check_rerender_output(dataset, out, request)  # a refusal is its sentence alone
    say(
        f"re-rendering {dataset} at {size}x{size} ({', '.join(chosen)}; {features} names; "
        f"{render_quality} quality) into {out}"
    )
    episodes_with_progress(
        lambda show: rerender(
            dataset,
            out,
            image_size=size,
            features=features,
            cameras=chosen,
            render_quality=render_quality,
            workers=workers,
            on_progress=show,
            command=command,
            keep_work=keep_work,
        ),
        request,
        out,
    )
