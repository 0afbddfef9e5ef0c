"""``libero-bench eval``: a LeRobot policy (from lerobot-train) evaluated in our simulator."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import (
    RenderQuality,
    quiet_environment,
    rollout_progress,
    say,
    split_list,
    user_errors,
)


@user_errors
def eval_cmd(
    policy: Annotated[
        Path, typer.Argument(help="A LeRobot policy: the pretrained_model/ folder lerobot-train writes.")
    ],
    tasks: Annotated[
        list[str],
        typer.Option(
            "--tasks",
            "-t",
            help="Tasks (libero_object/0, suite/name, a .bddl file), suites (libero_object) or suite folders "
            "made by libero-data (procedural tasks, variants); repeat or comma-separate.",
        ),
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Evaluation folder (created; an existing one resumes).")
    ],
    stored: Annotated[
        int, typer.Option("--stored", help="Rollouts per task from LIBERO's stored init states.", min=0)
    ] = 20,
    heldout: Annotated[
        int,
        typer.Option(
            "--heldout",
            help="Rollouts per task from held-out placements no demonstration started from.",
            min=0,
        ),
    ] = 20,
    max_steps: Annotated[
        int, typer.Option("--max-steps", help="Steps before a rollout is cut.", min=1)
    ] = 300,
    workers: Annotated[int, typer.Option("--workers", "-w", help="Parallel rollout processes.", min=1)] = 1,
    render_quality: RenderQuality = "full",
) -> None:
    """Evaluate a LeRobot policy (ACT, Diffusion Policy, ...) in simulation: every rollout stored, success with intervals.

    The policy's inputs are served from its declared features (either camera naming, any image size, the 8-D
    state) and its own pre- and post-processors run as in lerobot-eval.
    """
    quiet_environment()
    from libero_bench.policy_eval import EvalRequest, evaluate_policy, markdown

    request = EvalRequest(
        str(policy), tuple(split_list(tasks)), stored, heldout, max_steps, render_quality=render_quality
    )
    with rollout_progress() as (done, total):
        summary = evaluate_policy(request, out, workers=workers, on_result=done, on_total=total)
    say(markdown(summary))
    say(
        f"wrote {out / 'report.md'}, {out / 'report.json'}, {out / 'success.png'}, the rollouts in {out / 'rollouts'}"
    )
