"""A request for ``generate`` made from the user's choices: task names or indices turned into the
suite's, and the defaults that depend on the demonstration source (the steps after the goal)."""

from __future__ import annotations

from pathlib import Path

from libero_data.errors import InputError
from libero_data.pipeline.request import AFTER_GOAL, STANDARD, GenerateRequest
from libero_data.pipeline.sources import named_source
from libero_data.record.features import CAMERAS
from libero_data.sim.arm import ARM_INIT_NOISE


def resolve_request(
    suite: str,
    tasks: list[str] | None = None,
    *,
    episodes_per_task: int = 50,
    image_size: int = 128,
    seed: int = 0,
    max_attempts: int = 8,
    repo_id: str | None = None,
    starts: str = "sampler",
    features: str = "libero-data",
    cameras: tuple[str, ...] = CAMERAS,
    render_quality: str = "full",
    arm_noise: float = ARM_INIT_NOISE,
    max_length: int | str | None = STANDARD,
    after_goal: int | None = None,
    source: str = "",
) -> GenerateRequest:
    """Check the user's choices and turn task names/indices into suite indices. ``after_goal``
    None: :data:`AFTER_GOAL` where the source records steps after the goal (the expert), else 0."""
    from libero_data.tasks import get_suite

    records = named_source(source or "scripted").records_after_goal
    if after_goal is None:
        after_goal = AFTER_GOAL if records else 0
    elif after_goal and not records:
        raise InputError(
            f"the demonstration source {source!r} keeps its episodes as they were recorded: it records no steps "
            "after the goal (leave out --after-goal)",
            field="after_goal",
        )

    s = get_suite(suite)
    if tasks:
        indices = [s.task(ref).index for ref in tasks]
        if len(set(indices)) != len(indices):
            raise InputError("the task list names a task twice", field="tasks")
    else:
        indices = [t.index for t in s.tasks]
    for i in indices:
        s.tasks[i].require_buildable()  # a LIBERO-Plus task without its asset: one sentence naming it
    suite_id = str(Path(suite).resolve()) if s.path is not None else s.name
    return GenerateRequest(
        suite=suite_id,
        tasks=tuple(indices),
        episodes_per_task=episodes_per_task,
        image_size=image_size,
        seed=seed,
        max_attempts=max_attempts,
        repo_id=repo_id or f"libero-data/{s.name.replace('/', '-')}",  # plus/libero_object: one name
        starts=starts,
        features=features,
        cameras=tuple(cameras),
        render_quality=render_quality,
        arm_noise=float(arm_noise),
        max_length=max_length,
        after_goal=after_goal,
        source=source,
    )
