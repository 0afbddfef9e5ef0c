"""``libero-bench robustness``: a trained policy over perturbation kinds x severity levels."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from libero_bench.cli.options import (
    BatchSize,
    Device,
    EnvWorkers,
    KeepRollouts,
    MaxSteps,
    ReplanSteps,
    SentImageSize,
    Server,
    policy_or_server,
)
from libero_data.cli.common import (
    ExecutorKind,
    RayAddress,
    ViewRenderQuality,
    quiet_environment,
    rollout_progress,
    say,
    split_list,
    user_errors,
)
from libero_data.perturb.levels import KINDS  # the registry's kinds, for --help


@user_errors
def robustness_cmd(
    policy: Annotated[
        Path | None,
        typer.Argument(
            help="A libero-bench run folder (its final checkpoint) or a LeRobot pretrained_model/ folder "
            "(or --server)."
        ),
    ] = None,
    tasks: Annotated[
        list[str] | None,
        typer.Option(
            "--tasks", "-t", help="Source tasks (libero_object/0, suite/name); repeat or comma-separate."
        ),
    ] = None,
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Sweep folder (created; an existing one resumes).")
    ] = None,
    kinds: Annotated[
        list[str] | None,
        typer.Option(
            "--kinds",
            help=f"Perturbation kinds: {', '.join(KINDS)} (default: all {len(KINDS)}).",
        ),
    ] = None,
    levels: Annotated[
        list[str] | None, typer.Option("--levels", help="Severity levels 1-5 (default all); comma-separate.")
    ] = None,
    rollouts: Annotated[
        int, typer.Option("--rollouts", "-n", help="Rollouts per task and cell (held-out placements).", min=1)
    ] = 10,
    max_steps: MaxSteps = "suite",
    seed: Annotated[
        int, typer.Option("--seed", help="Seed of the variants (which values each level draws).")
    ] = 0,
    server: Server = None,
    device: Device = None,
    workers: EnvWorkers = 1,
    batch_size: BatchSize = None,
    executor: ExecutorKind = "local",
    ray_address: RayAddress = None,
    image_size: SentImageSize = None,
    replan_steps: ReplanSteps = 5,
    render_quality: ViewRenderQuality = "full",
    keep_work: KeepRollouts = False,
) -> None:
    """Evaluate a policy on its tasks perturbed along kinds x levels: a table and a heatmap of success with
    95% intervals, the drop from the unperturbed tasks, and every rollout stored.

    Every cell starts from the same held-out placements of its source task, so kinds that keep the scene
    (camera, lighting, texture, noise, robot start, language) are compared start for start. The policy runs
    once, on --device, batched over --batch-size environments stepped by --workers processes; --server
    evaluates a served policy (see libero-bench eval --help).
    """
    quiet_environment()
    from libero_bench.robustness.cells import REPORT, SweepRequest
    from libero_bench.robustness.sweep import sweep
    from libero_bench.rollouts.loop import RolloutResources
    from libero_data.errors import InputError
    from libero_data.perturb.levels import KINDS
    from libero_data.runtime.jobs import JobPlacement
    from libero_data.tasks.horizons import parse_step_limit

    if not tasks:
        raise InputError("name the source tasks to perturb", field="tasks")
    if out is None:
        raise InputError("name the sweep folder", field="out")
    reference = policy_or_server(policy, server)
    chosen_levels = []
    for value in split_list(levels) or ["1", "2", "3", "4", "5"]:
        if not value.isdigit():
            raise InputError(f"a level must be 1..5, got {value!r}", field="levels")
        chosen_levels.append(int(value))
    request = SweepRequest(
        tasks=tuple(split_list(tasks)),
        kinds=tuple(split_list(kinds) or KINDS),
        levels=tuple(sorted(set(chosen_levels))),
        rollouts=rollouts,
        max_steps=parse_step_limit(max_steps),
        seed=seed,
        render_quality=render_quality,
        image_size=image_size,
        replan_steps=replan_steps,
    )
    execution = RolloutResources(JobPlacement(executor, workers, ray_address), batch_size, device)
    from libero_bench.rollouts.policy_kinds import check_policy

    check_policy(reference, image_size, replan_steps)  # one sentence before any output
    with rollout_progress() as (done, total):
        sweep(
            reference, request, out, execution=execution, on_result=done, on_total=total, keep_work=keep_work
        )
    say((out / f"{REPORT}.md").read_text())
    say(f"wrote {out / f'{REPORT}.md'}, {out / f'{REPORT}.json'}, {out / f'{REPORT}.png'}")
