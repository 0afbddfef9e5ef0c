"""What a generated dataset says about itself: ``meta/libero.json``, its card (``README.md``) and
the card's length plot.

All are derived from the request, the finished slots and shards and the suite: per task its goal,
the episodes kept, the attempts and the successes within its standard step limit; the episodes'
lengths against it and the length bound with what it cost (:mod:`~libero_data.pipeline.length_card`);
the settings, versions, expert codes, and the machines and renderers that made the episodes; for a
generated suite, the generator's settings. What the demonstrations are (the summary, where they
started, the card's sections and the settings rows of their own) comes from their source
(:mod:`~libero_data.pipeline.sources`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from libero_data.pipeline.episodes import EpisodeDone
from libero_data.pipeline.length_card import (
    LENGTH_PLOT,
    TaskLengths,
    after_goal_words,
    bound_words,
    dataset_lengths,
    dataset_note,
    lengths_card,
    report_lengths,
    report_note,
)
from libero_data.pipeline.request import GenerateRequest, Slot
from libero_data.pipeline.sources.scripted import start_note, start_words

if TYPE_CHECKING:
    from libero_data.cards.expert_files import Measured


def describe_dataset(
    request: GenerateRequest,
    slots: list[Slot],
    status: Mapping[str, EpisodeDone],
    shards: list[Path],
    width: int,
    *,
    command: str,
    complete: bool,
) -> tuple[dict[str, Any], dict[str, str], str, dict[str, bytes]]:
    """The dataset's metadata, its tasks' BDDL texts, its card and the card's files (the length
    plot), by path within the dataset."""
    from libero_data import provenance
    from libero_data.cards import render_card
    from libero_data.cards.card import FAST_IMAGE_NOTE, FULL_IMAGE_NOTE
    from libero_data.cards.lengths import length_line
    from libero_data.pipeline.sources import source_of
    from libero_data.runtime.versions import versions
    from libero_data.tasks import get_suite

    suite = get_suite(request.suite)
    infos = [json.loads((shard / "episode.json").read_text()) for shard in shards]
    frames = sum(int(info["length"]) for info in infos)
    codes = {str(info.get("expert_code", "unknown")) for info in infos}
    machines, renderers = provenance.machines(infos), provenance.renderers(infos)
    render = provenance.render_summary(infos, request.render_quality)
    keys_in = {p.name for p in shards}
    part = source_of(request).card(request, suite.name, infos)  # what the demonstrations are
    lengths = dataset_lengths(request, suite, slots, status, infos, of_attempts=part.success.of_attempts)
    tasks = []
    bddl = {}
    for position, row in enumerate(lengths):
        episodes = sum(1 for s in slots if s.position == position and s.key in keys_in)
        tasks.append(_card_task(row.task, episodes, row.attempts, row.successes, row.within))
        bddl[row.task.name] = row.task.bddl_path.read_text()
    section, plot = lengths_card(
        suite, lengths, dataset_note(request, lengths), LENGTH_PLOT, success_header=part.success.header
    )
    vers = versions()
    settings = {
        "suite": suite.name,
        "tasks": ", ".join(str(i) for i in request.tasks),
        "episodes per task (requested)": str(request.episodes_per_task),
        "image size": f"{request.image_size}×{request.image_size}",
        "seed": str(request.seed),
        "starts": start_words(request.starts, request.arm_noise),
        "feature names": request.features,
        "render quality": provenance.render_line(render),
        "attempts per episode (at most)": str(request.max_attempts),
        "length bound (steps)": bound_words(request, lengths),
        "steps after the goal": after_goal_words(request),
        "fps": "20",
        "episode length (steps)": length_line([int(info["length"]) for info in infos], suite.name),
        "complete": "yes" if complete else "no (generation still running or interrupted)",
        "expert code": ", ".join(sorted(codes)),
        **{f"version: {k}": v for k, v in vers.items()},
        **provenance.card_settings(machines, renderers),
        **_generator_settings(suite.manifest(), len(suite.tasks)),
        **_perturbation_rows([suite.task(i) for i in request.tasks]),
    }
    card = render_card(
        title=f"libero-data · {suite.name}",
        summary=part.summary,
        suite=suite.name,
        repo_id=request.repo_id,
        load_path=".",
        command=command
        or f"libero-data generate --suite {suite.name} --episodes-per-task {request.episodes_per_task} --seed {request.seed}",
        tasks=tasks,
        frames=frames,
        fps=20,
        image_size=request.image_size,
        sim_state_width=width,
        settings=part.apply(settings),
        start_note=part.start_note,
        lengths=section,
        camera_keys=request.layout.camera_keys,
        image_note=FAST_IMAGE_NOTE if request.render_quality == "fast" else FULL_IMAGE_NOTE,
        success=part.success,
        **part.card_sections(),
    )
    meta = {
        "request": request.to_dict(),
        "versions": vers,
        "expert_code": sorted(codes),
        "machines": machines,
        "renderers": renderers,
        "render": render,
        "complete": complete,
        "sim_state_width": width,
        "tasks": [_task_meta(t, row) for t, row in zip(tasks, lengths, strict=True)],
    }
    return meta, bddl, card, ({LENGTH_PLOT: plot} if plot is not None else {})


def _task_meta(t: Any, lengths: TaskLengths) -> dict[str, Any]:
    return {
        "index": t.index,
        "name": t.name,
        "language": t.language,
        "goal": t.goal,
        "episodes": t.episodes,
        "attempts": t.attempts,
        "successes": t.successes,
        "standard_limit": lengths.limit,
        "within_standard_limit": lengths.within,
        "length_bound": lengths.bound,
        "attempts_stopped_at_bound": lengths.too_long,
    }


def _card_task(task: Any, episodes: int, attempts: int, successes: int, within: int | None) -> Any:
    from libero_data.bddl import formula_text
    from libero_data.cards import CardTask

    return CardTask(
        task.index,
        task.name,
        task.language,
        formula_text(task.problem.goal),
        episodes,
        attempts,
        successes,
        within,
    )


def _perturbation_rows(tasks: list[Any]) -> dict[str, str]:
    """A card row per task whose scene is perturbed (kind, level and the values drawn; the
    BDDL file in ``meta/bddl/`` carries the same record, which reproduces it)."""
    from libero_data.perturb.spec import Perturbation

    rows = {}
    for task in tasks:
        p = Perturbation.from_json(task.problem.perturbation)
        if p is not None:
            rows[f"perturbation: {task.name}"] = p.describe()
    return rows


def _generator_settings(manifest: Mapping[str, Any], kept: int) -> dict[str, str]:
    """The card rows of a generated suite's generator (none for a shipped suite)."""
    generator = manifest.get("generator")
    if not generator:
        return {}
    g = generator["settings"]
    return {
        "procedural generator: seed": str(g["seed"]),
        "procedural generator: candidates / kept": f"{generator.get('candidates', g['n'])} / {kept}",
        "procedural generator: settings": json.dumps(g, sort_keys=True),
        "procedural generator: acceptance": (
            f"the expert solved at least half of {g['check_inits']} initial states drawn by LIBERO's sampler "
            "(every candidate and its verdict: procedural_report.md)"
        ),
    }


def suite_card(
    suite_name: str,
    measured: Mapping[str, Measured],
    *,
    episodes_per_task: int = 50,
    image_size: int = 128,
    seed: int = 0,
    measured_by: dict[str, str] | None = None,
    lengths_image: str = "lengths.png",
) -> tuple[str, bytes | None]:
    """The card ``generate --suite`` writes with these settings, before any data exists, and its
    length plot (None where the report recorded no lengths), which the card shows from
    ``lengths_image`` (a path relative to the card).

    ``measured`` maps task names to what the expert report measured of them (successes, those
    within the standard limit, the lengths: ``libero_data.cards.expert_files.read_measured``);
    frame counts are only known once generated. ``measured_by`` (the report's expert code, init
    states, seed) is stated beside them.
    """
    from libero_data.cards import render_card
    from libero_data.pipeline.request import AFTER_GOAL, sim_state_width
    from libero_data.runtime.versions import versions
    from libero_data.tasks import get_suite

    suite = get_suite(suite_name)
    request = GenerateRequest(
        suite=suite.name,
        tasks=tuple(t.index for t in suite.tasks),
        episodes_per_task=episodes_per_task,
        image_size=image_size,
        seed=seed,
        repo_id=f"libero-data/{suite.name.replace('/', '-')}",  # plus/libero_object: one name
        after_goal=AFTER_GOAL,  # generate's default for the expert
    )
    lengths = report_lengths(request, suite, measured)
    tasks = []
    for row in lengths:
        m = measured.get(row.task.name)
        tasks.append(
            _card_task(row.task, episodes_per_task, row.attempts, m.successes if m else 0, row.within)
        )
    section, plot = lengths_card(suite, lengths, report_note(lengths), lengths_image)
    settings = {
        "suite": suite.name,
        "episodes per task": str(episodes_per_task),
        "image size": f"{image_size}×{image_size}",
        "seed": str(seed),
        "starts": start_words(request.starts, request.arm_noise),
        "render quality": "full: LIBERO's own renderer, pixel for pixel (`--render-quality fast` draws "
        "simplified visual meshes and states their measured difference)",
        "attempts per episode (at most)": str(request.max_attempts),
        "length bound (steps)": bound_words(request, lengths),
        "steps after the goal": after_goal_words(request),
        "fps": "20",
        **{f"version: {k}": v for k, v in versions().items()},
        **{f"expert report: {k}": v for k, v in (measured_by or {}).items()},
    }
    by = ", ".join(f"{k} {v}" for k, v in (measured_by or {}).items())
    card = render_card(
        title=f"libero-data · {suite.name}",
        summary=(
            f"Scripted demonstrations of the LIBERO suite `{suite.name}` in LeRobot v3 format. This card was "
            "rendered before generation, from the expert's measured success rates (`libero-data expert-report`, "
            "one attempt per stored init state); `libero-data generate` writes the same card with the dataset's "
            "own counts."
        ),
        suite=suite.name,
        repo_id=request.repo_id,
        load_path=".",
        command=f"libero-data generate --suite {suite.name} --out <dir>",
        tasks=tasks,
        frames=None,
        fps=20,
        image_size=image_size,
        sim_state_width=sim_state_width(request),
        settings=settings,
        start_note=start_note(request.starts, episodes_per_task, request.arm_noise),
        lengths=section,
        expert_note=(
            "Here: successes over the first attempts from the stored init states, as measured by the expert report"
            + (f" ({by})." if by else ".")
        ),
    )
    return card, plot
