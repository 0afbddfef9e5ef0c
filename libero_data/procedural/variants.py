"""Robustness variants of shipped tasks: each differs from its source in one requested way, at
a severity level 1–5. Each kind is one module of :mod:`libero_data.perturb.kinds` (what it
changes, its magnitudes per level): ``layout``, ``distractors``, ``swap`` and ``language``
rewrite the task's BDDL; ``camera``, ``robot_init``, ``lighting``, ``texture`` and ``noise``
leave it as the source's with a perturbation record (:mod:`libero_data.perturb.spec`), which the
simulator applies.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Iterator

import numpy as np

from libero_data.bddl.model import Problem
from libero_data.perturb.kinds import get_kind
from libero_data.perturb.kinds.base import VariantSource
from libero_data.perturb.kinds.placement import scene_of
from libero_data.perturb.levels import LEVELS
from libero_data.scenes.catalogue import Catalogue, load_catalogue
from libero_data.scenes.sampler import SampledTask, SamplingError
from libero_data.seeding import variant_level_rng


def make_variant(
    source: Problem,
    task_id: str,
    kind: str,
    rng: np.random.Generator,
    catalogue: Catalogue | None = None,
    language: str | None = None,
    level: int = 1,
) -> Problem:
    """One ``kind`` variant of ``source`` at ``level``; raises :class:`SamplingError` where none fits.

    ``language`` is the instruction policies are given (the task's; default the BDDL's).
    Every variant carries it in its BDDL (``:language``).
    """
    from libero_data.perturb.levels import KINDS
    from libero_data.perturb.spec import sample

    if kind not in KINDS:
        raise SamplingError(f"unknown variant kind {kind!r}; known: {', '.join(KINDS)}")
    if level not in LEVELS:
        raise SamplingError(f"the level must be 1..5, got {level}")
    language = (language or source.language).strip().lower()
    source = dataclasses.replace(source, language=language)
    chosen = get_kind(kind)
    if not chosen.rewrites_task:
        perturbation = sample(kind, level, int(rng.integers(1 << 31)))
        return dataclasses.replace(source, perturbation=perturbation.to_json())
    if not chosen.needs_layout:
        return chosen.vary(VariantSource(source, task_id, level), rng)
    catalogue = catalogue or load_catalogue()
    scene = scene_of(task_id, catalogue)
    if scene is None:
        raise SamplingError(f"{task_id} has no scene layout in the catalogue")
    return chosen.vary(VariantSource(source, task_id, level, scene, catalogue), rng)


def variant_tasks(
    suite: str,
    kinds: Iterable[str],
    seed: int,
    tasks: Iterable[str] | None = None,
    levels: Iterable[int] = (1,),
) -> Iterator[tuple[SampledTask | None, str, str, str]]:
    """Variants of a shipped suite's tasks, in the order task × kind × level (as ``sample_tasks``).

    A variant is named ``<task>__<kind>`` at level 1 and ``<task>__<kind>_l<level>`` above."""
    from libero_data.tasks import get_suite

    s = get_suite(suite)
    chosen = [s.task(t) for t in tasks] if tasks else list(s.tasks)
    from libero_data.perturb.levels import KINDS

    kinds = list(kinds)
    for k in kinds:
        if k not in KINDS:
            raise SamplingError(f"unknown variant kind {k!r}; known: {', '.join(KINDS)}")
    levels = list(levels)
    for task in chosen:
        for j, kind in enumerate(kinds):
            for level in levels:
                rng = variant_level_rng(seed, task.index, j, level)
                template = f"variant:{kind}" if level == 1 else f"variant:{kind}:{level}"
                try:
                    problem = make_variant(
                        task.problem, task.id, kind, rng, language=task.language, level=level
                    )
                except SamplingError as exc:
                    yield None, task.id, template, str(exc)
                    continue
                name = f"{task.name}__{kind}" + ("" if level == 1 else f"_l{level}")
                yield SampledTask(name, task.id, template, problem), task.id, template, ""
