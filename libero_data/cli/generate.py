"""``libero-data generate``: demonstrations of shipped tasks, of new procedural tasks, or of
robustness variants, as a LeRobot dataset with MCAP logs and a card."""

from __future__ import annotations

import os
import shlex
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer

from libero_data.cli.common import (
    ExecutorKind,
    PlusAssetsOption,
    PlusFilesOption,
    RayAddress,
    RenderQuality,
    Seed,
    Workers,
    fail,
    progress,
    say,
    split_list,
    use_plus,
    user_errors,
)
from libero_data.cli.episode_options import AfterGoal, MaxAttempts, MaxLength
from libero_data.perturb.levels import KINDS, SCENE_KINDS  # the registry's kinds, for --help
from libero_data.pipeline.sources import source_choices  # the registry's sources, for --help

Tasks = Annotated[
    list[str] | None,
    typer.Option(
        "--tasks",
        "-t",
        help="Task indices or names within the suite (repeat or comma-separate); default: all.",
    ),
]
Procedural = Annotated[
    int | None,
    typer.Option(
        "--procedural",
        help="Sample this many new tasks (seeded by --seed), keep those the expert solves from at least "
        "half of their sampled initial states, and write them with their dataset into --out.",
        min=1,
    ),
]
Scene = Annotated[
    list[str] | None,
    typer.Option(
        "--scene", help="With --procedural: scene layouts to sample from (see `libero-data scenes`)."
    ),
]
Template = Annotated[
    list[str] | None,
    typer.Option(
        "--template", help="With --procedural: behaviour templates to sample from (see `libero-data scenes`)."
    ),
]
TasksOnly = Annotated[
    bool,
    typer.Option(
        "--tasks-only",
        help="With --procedural/--variants-of: stop once the tasks are sampled, checked and written (no dataset).",
    ),
]
VariantsOf = Annotated[
    str | None,
    typer.Option(
        "--variants-of",
        help="Make robustness variants of this suite's tasks (--tasks to choose some; SUITE/TASK for one), each proven "
        "feasible with the expert, with their dataset, into --out.",
    ),
]
Kinds = Annotated[
    list[str] | None,
    typer.Option(
        "--kinds",
        help=f"With --variants-of: {', '.join(KINDS)} (default: the {len(SCENE_KINDS)} that rewrite the task, "
        f"{', '.join(SCENE_KINDS)}).",
    ),
]
Levels = Annotated[
    list[str] | None,
    typer.Option(
        "--level",
        help="With --variants-of: severity levels 1-5 (repeat or comma-separate; default 1). Magnitudes per level: "
        "docs/procedural-and-robustness.md.",
    ),
]
EpisodesPerTask = Annotated[
    int,
    typer.Option(
        "--episodes-per-task",
        "-n",
        help="Successful episodes to keep per task.",
        min=1,
    ),
]
Features = Annotated[
    str,
    typer.Option(
        "--features",
        help="Feature names: 'libero-data' (eye-in-hand camera observation.images.wrist_image, as LeRobot's "
        "Hub LIBERO datasets; 128x128 by default) or 'lerobot-libero' (observation.images.image2, as LeRobot's "
        "LIBERO environment; 256x256 by default).",
    ),
]
GenImageSize = Annotated[
    int | None,
    typer.Option(
        "--image-size",
        help="Camera image size in pixels (square); default: the feature names' size.",
        min=32,
        max=512,
    ),
]
Starts = Annotated[
    str,
    typer.Option(
        "--starts",
        help="Where episodes start: 'sampler' (LIBERO's placement sampler, seeds no evaluation uses) or "
        "'stored' (LIBERO's 50 stored init states, which the paper's evaluation starts from, then the sampler).",
    ),
]
Source = Annotated[
    str | None,
    typer.Option(
        "--source",
        help="The demonstration source that makes the episodes, by name (default: scripted, the expert): "
        f"{source_choices()}.",
    ),
]
ArmNoise = Annotated[
    float,
    typer.Option(
        "--arm-noise",
        help="Gaussian noise (rad, per arm joint) on the arm's pose at a sampler start, drawn from the episode's "
        "seed: 0.02 is what LIBERO's stored init states have; 0 starts every episode from LIBERO's one arm pose "
        "(datasets made before this option existed did).",
        min=0.0,
        max=0.5,
    ),
]
RepoId = Annotated[
    str | None,
    typer.Option("--repo-id", help="Dataset id recorded in the metadata; default libero-data/<suite>."),
]
KeepWork = Annotated[
    bool,
    typer.Option(
        "--keep-work",
        help="Keep the work files (.libero-data/: search records, shards) once the dataset is complete; "
        "by default the finished folder holds the dataset only.",
    ),
]
PublishEvery = Annotated[
    float,
    typer.Option(
        "--publish-every",
        help="Seconds at least between snapshots of the growing dataset in --out (longer once "
        "a snapshot of a big dataset takes time: publishing is kept under 5% of the run).",
        min=0.0,
    ),
]


@user_errors
def generate_cmd(
    out: Annotated[
        Path,
        typer.Option("--out", "-o", help="Dataset folder to create (or to continue, after an interruption)."),
    ],
    suite: Annotated[
        str | None,
        typer.Option(
            "--suite", "-s", help="Suite name (libero_object, ...) or a suite folder; default libero_object."
        ),
    ] = None,
    tasks: Tasks = None,
    procedural: Procedural = None,
    scene: Scene = None,
    template: Template = None,
    tasks_only: TasksOnly = False,
    variants_of: VariantsOf = None,
    kinds: Kinds = None,
    level: Levels = None,
    episodes_per_task: EpisodesPerTask = 50,
    image_size: GenImageSize = None,
    features: Features = "libero-data",
    starts: Starts = "sampler",
    source: Source = None,
    arm_noise: ArmNoise = 0.02,
    render_quality: RenderQuality = "full",
    workers: Workers = 1,
    seed: Seed = 0,
    max_attempts: MaxAttempts = 8,
    max_length: MaxLength = "standard",
    after_goal: AfterGoal = None,
    repo_id: RepoId = None,
    publish_every: PublishEvery = 60.0,
    keep_work: KeepWork = False,
    executor: ExecutorKind = "local",
    ray_address: RayAddress = None,
    plus: PlusFilesOption = None,
    plus_assets: PlusAssetsOption = None,
) -> None:
    """Make demonstrations of a suite's tasks as a LeRobot v3 dataset, with MCAP logs and a dataset card.

    The scripted expert makes them unless --source names another demonstration source. With --procedural or --variants-of, new tasks (procedural ones, robustness variants) are made and written into --out first, with their dataset. Episodes are searched without cameras and only kept episodes are rendered. Interrupt at any time (even with kill -9) and run the same command again: finished episodes are kept.
    """
    from libero_data.pipeline.request import parse_max_length
    from libero_data.pipeline.resolve import resolve_request
    from libero_data.record.features import PROFILE_IMAGE_SIZE
    from libero_data.runtime.jobs import JobPlacement
    from libero_data.runtime.memory import limit_malloc_arenas

    os.environ.setdefault("SVT_LOG", "1")  # the AV1 encoder's banner, once per video
    limit_malloc_arenas()  # with --workers 1 this process renders and writes every episode
    runner = JobPlacement(executor, workers, ray_address)  # checked before any work
    use_plus(plus, plus_assets)
    length_bound = parse_max_length(max_length)  # a bad value fails before any task is sampled
    task_refs = split_list(tasks)
    _check_combination(suite, task_refs, procedural, variants_of, scene, template, kinds or level, tasks_only)
    if procedural is not None or variants_of is not None:
        suite = str(
            _procedural_suite(
                out, procedural, variants_of, seed, scene, template, kinds, task_refs, runner, _levels(level)
            )
        )
        task_refs = []
        if tasks_only:
            say(f"tasks written to {out}; `libero-data tasks --suite {out}` lists them")
            return
    request = resolve_request(
        suite or "libero_object",
        task_refs or None,
        episodes_per_task=episodes_per_task,
        image_size=image_size or PROFILE_IMAGE_SIZE.get(features, 128),
        seed=seed,
        max_attempts=max_attempts,
        repo_id=repo_id,
        starts=starts,
        features=features,
        render_quality=render_quality,
        arm_noise=arm_noise,
        max_length=length_bound,
        after_goal=after_goal,
        source=source or "",
    )
    if source:  # an unknown name, or a source that cannot make this request: one sentence now
        from libero_data.pipeline.sources import source_of

        source_of(request)
    command = "libero-data generate " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    from libero_data.pipeline.generate import check_output

    check_output(request, out)  # a refusal is its sentence alone: no header, no empty progress bar
    say(
        f"generating {len(request.tasks)} task(s) × {request.episodes_per_task} episode(s) of "
        f"{suite or 'libero_object'} into {out} {runner.describe()}"
    )
    _generate(request, out, workers, executor, ray_address, publish_every, command, keep_work)


def _check_combination(
    suite: str | None,
    task_refs: list[str],
    procedural: int | None,
    variants_of: str | None,
    scene: list[str] | None,
    template: list[str] | None,
    kinds: list[str] | None,
    tasks_only: bool,
) -> None:
    if procedural is not None and variants_of is not None:
        raise typer.BadParameter("choose --procedural or --variants-of, not both")
    if procedural is not None and (suite is not None or task_refs):
        raise typer.BadParameter("--procedural makes its own suite; leave out --suite and --tasks")
    if variants_of is not None and suite is not None:
        raise typer.BadParameter("--variants-of makes its own suite; leave out --suite")
    if procedural is None and variants_of is None and (scene or template or kinds or tasks_only):
        raise typer.BadParameter(
            "--scene/--template need --procedural, --kinds and --level need --variants-of, --tasks-only needs either"
        )


def _generate(
    request: Any,
    out: Path,
    workers: int,
    executor: str,
    ray_address: str | None,
    publish_every: float,
    command: str,
    keep_work: bool,
) -> None:
    from libero_data.pipeline.generate import generate

    def work(show: Callable[[Any], None]) -> Any:
        return generate(
            request,
            out,
            workers=workers,
            on_progress=show,
            command=command,
            publish_every=publish_every,
            executor=executor,
            ray_address=ray_address,
            keep_work=keep_work,
        )

    episodes_with_progress(work, request, out)


def episodes_with_progress(work: Callable[[Callable[[Any], None]], Any], request: Any, out: Path) -> Any:
    """Run ``work(on_progress)`` (generating or re-rendering episodes) under a progress bar,
    then say what was made and how to load it."""
    start = time.monotonic()
    with progress("failed", "attempts", "published") as bar:
        fields = {"failed": "failed 0", "attempts": "attempts 0", "published": "published 0"}
        job = bar.add_task("episodes", total=len(request.tasks) * request.episodes_per_task, **fields)

        def show(p: Any) -> None:
            bar.update(
                job,
                completed=p.done + p.failed,
                failed=f"failed {p.failed}",
                attempts=f"attempts {p.attempts}",
                published=f"published {p.published}",
            )

        try:
            result = work(show)
        except KeyboardInterrupt:
            raise fail(
                f"interrupted; finished episodes are kept in {out}, run the same command to continue",
                code=130,
            ) from None
    minutes = (time.monotonic() - start) / 60
    say(
        f"done: {result.published} episodes in {out} ({result.failed} given up after {request.max_attempts} "
        f"attempts; {minutes:.1f} min)"
    )
    say("load it with:")
    say(f'  datasets.load_dataset("{out}", split="train")')
    say(f'  LeRobotDataset("{request.repo_id}", root="{out}")')
    return result


def _levels(values: list[str] | None) -> tuple[int, ...]:
    from libero_data.errors import InputError

    levels = []
    for value in split_list(values) or ["1"]:
        if not value.isdigit() or not 1 <= int(value) <= 5:
            raise InputError(f"a level must be 1..5, got {value!r}", field="level")
        levels.append(int(value))
    return tuple(sorted(set(levels)))


def _procedural_suite(
    out: Path,
    n: int | None,
    variants_of: str | None,
    seed: int,
    scenes: list[str] | None,
    templates: list[str] | None,
    kinds: list[str] | None,
    tasks: list[str],
    executor: Any,
    levels: tuple[int, ...] = (1,),
) -> Path:
    """Sample new tasks (or derive variants), check them with the expert, write them into ``out``."""
    from libero_data.errors import InputError
    from libero_data.perturb.levels import KINDS, SCENE_KINDS
    from libero_data.procedural.suite import ProceduralSettings, make_suite

    if variants_of is not None:
        from libero_data.tasks import get_suite

        variants_of, tasks = _variant_source(variants_of, tasks)
        source = get_suite(variants_of)
        chosen_kinds = split_list(kinds) or list(SCENE_KINDS)
        bad = [k for k in chosen_kinds if k not in KINDS]
        if bad:
            raise InputError(f"unknown variant kind {bad[0]!r}; known: {', '.join(KINDS)}", field="kinds")
        chosen = tuple(str(source.task(t).index) for t in tasks)
        n = (len(chosen) or len(source.tasks)) * len(chosen_kinds) * len(levels)
        settings = ProceduralSettings(
            n=n, seed=seed, variants_of=variants_of, kinds=tuple(chosen_kinds), tasks=chosen, levels=levels
        )
    else:
        assert n is not None
        settings = ProceduralSettings(
            n=n, seed=seed, scenes=tuple(split_list(scenes)), templates=tuple(split_list(templates))
        )
    kept = 0
    with progress("kept", eta=False) as bar:
        job = bar.add_task("tasks", total=settings.n, kept="kept 0")

        def seen(v: Any) -> None:
            nonlocal kept
            kept += v.kept
            bar.update(job, advance=1, kept=f"kept {kept} · {(v.language or v.reason)[:60]}")

        try:
            verdicts = make_suite(out, settings, on_verdict=seen, executor=executor)
        except KeyboardInterrupt:
            raise fail(
                f"interrupted; checked tasks are kept in {out}, run the same command to continue", code=130
            ) from None
    kept_n = sum(v.kept for v in verdicts)
    say(f"procedural: {kept_n} of {settings.n} sampled tasks kept (report: {out / 'procedural_report.md'})")
    if kept_n == 0:
        raise fail(f"none of the {settings.n} sampled tasks was kept; see {out / 'procedural_report.md'}")
    return out


def _variant_source(variants_of: str, tasks: list[str]) -> tuple[str, list[str]]:
    """``SUITE/TASK`` (e.g. ``libero_object/0``) is shorthand for ``SUITE --tasks TASK``; a suite
    folder's path stays whole."""
    from libero_data.errors import InputError

    if "/" not in variants_of or Path(variants_of).is_dir():
        return variants_of, tasks
    suite, task = variants_of.rsplit("/", 1)
    if tasks:
        raise InputError(
            f"--variants-of {variants_of} names a task already; leave out --tasks or give the suite alone",
            field="tasks",
        )
    return suite, [task]
