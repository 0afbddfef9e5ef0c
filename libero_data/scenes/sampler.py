"""Sampling new tasks: scene + objects + placements + predicates + language → BDDL.

Same seed, same tasks. Objects start in the rectangles where LIBERO's own tasks put
movable objects in that scene layout, never overlapping (footprints measured from the
assets); their init regions are small squares around the drawn centres, as LIBERO writes
them, so LIBERO's sampler draws each initial state inside them. A task equal to another
one (same scene, objects and goal up to instance names), shipped or sampled, is rejected.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from libero_data.bddl.model import And, Atom, Entity, Problem, Region, atoms
from libero_data.errors import InputError
from libero_data.scenes.catalogue import Catalogue, SceneSpec, load_catalogue
from libero_data.scenes.templates import TEMPLATES, Draft, instantiate
from libero_data.seeding import sampler_rng

#: Default mix (kept tasks across scenes and templates); every template is possible.
HALF_WIDTH = 0.015  # init squares: LIBERO's sampler draws the object's centre in ±this
DRAWS_PER_TASK = 5  # distractor draws before a repeated task is rejected as a duplicate
GAP = 0.02  # free space between two objects' footprints (metres)


class SamplingError(InputError):
    """A task could not be drawn (no scene hosts the template, or no placement fits)."""


@dataclass(frozen=True)
class SampledTask:
    name: str
    scene: str
    template: str
    problem: Problem

    @property
    def language(self) -> str:
        return self.problem.language


def signature(problem: Problem) -> tuple:
    """What makes two tasks the same: scene, fixtures, objects and goal, up to instance names."""
    categories = {e.name: e.category for e in problem.entities}
    regions = {r.full_name: (categories.get(r.target, r.target), r.name) for r in problem.regions}

    def arg(name: str) -> object:
        if name in categories:
            return categories[name]
        return regions.get(name, name)

    goal = tuple(
        sorted((a.predicate.lower(), tuple(map(str, map(arg, a.args)))) for a in atoms(problem.goal))
    )
    return (
        problem.problem,
        tuple(sorted(f.category for f in problem.fixtures)),
        tuple(sorted(o.category for o in problem.objects)),
        goal,
    )


def shipped_signatures() -> set[tuple]:
    from libero_data.tasks import get_suite

    return {
        signature(t.problem)
        for s in ("libero_spatial", "libero_object", "libero_goal", "libero_10", "libero_90")
        for t in get_suite(s).tasks
    }


def shipped_instructions(catalogue: Catalogue) -> set[tuple[str, str]]:
    """(scene layout, instruction) of every shipped task."""
    from libero_data.tasks import get_task

    return {
        (scene_id, get_task(ref).language)
        for scene_id, spec in catalogue.scenes.items()
        for ref in spec.sources
    }


def _place(
    rng: np.random.Generator, scene: SceneSpec, radii: list[float], tries: int = 200
) -> list[tuple[float, float]] | None:
    """Centres for objects of these radii inside the scene's boxes, footprints apart."""
    boxes = np.asarray(scene.boxes, dtype=float)
    placed: list[tuple[float, float, float]] = []
    for r in radii:
        for _ in range(tries):
            x0, y0, x1, y1 = boxes[rng.integers(len(boxes))]
            c = (float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)))
            if all(np.hypot(c[0] - px, c[1] - py) >= r + pr + GAP + 2 * HALF_WIDTH for px, py, pr in placed):
                placed.append((c[0], c[1], r))
                break
        else:
            return None
    return [(x, y) for x, y, _ in placed]


def build_problem(
    draft: Draft,
    scene: SceneSpec,
    catalogue: Catalogue,
    distractors: list[str],
    centres: list[tuple[float, float]],
) -> Problem:
    table = scene.table
    regions: list[Region] = []
    init: list[Atom] = []
    for f in scene.fixtures:
        region = f"{f.category}_init_region"
        regions.append(Region(region, table, (f.ranges,), f.yaw))
        init.append(Atom("On", (f.name, f"{table}_{region}")))
    objects: list[Entity] = []
    for category, (x, y) in zip([*draft.objects, *distractors], centres, strict=True):
        name = f"{category}_1"
        region = f"{category}_init_region"
        box = (
            round(x - HALF_WIDTH, 4),
            round(y - HALF_WIDTH, 4),
            round(x + HALF_WIDTH, 4),
            round(y + HALF_WIDTH, 4),
        )
        regions.append(Region(region, table, (box,), (0.0, 0.0)))
        objects.append(Entity(name, category))
        init.append(Atom("On", (name, f"{table}_{region}")))
    for f in scene.fixtures:
        regions.extend(Region(r, f.name) for r in f.regions)
    for o in objects:
        regions.extend(Region(r, o.name) for r in catalogue.objects[o.category].regions)
    fixtures = (Entity(table, scene.table_category), *(Entity(f.name, f.category) for f in scene.fixtures))
    return Problem(
        problem=scene.problem,
        language=draft.language,
        regions=tuple(regions),
        fixtures=fixtures,
        objects=tuple(objects),
        obj_of_interest=tuple(draft.interest),
        init=tuple(init + draft.init),
        goal=And(tuple(draft.goal)),
    )


def task_name(scene: SceneSpec, language: str) -> str:
    """LIBERO's naming: ``<SCENE>_<instruction words>`` (a scene prefix keeps names unique)."""
    return f"{scene.id.upper()}_" + "_".join(language.split())


def sample_tasks(
    n: int,
    seed: int,
    *,
    scenes: Iterable[str] | None = None,
    templates: Iterable[str] | None = None,
    max_distractors: int = 2,
    catalogue: Catalogue | None = None,
    known: set[tuple] | None = None,
) -> Iterator[tuple[SampledTask | None, str, str, str]]:
    """Draw ``n`` candidate tasks: yields (task or None, scene, template, why rejected).

    ``known`` holds signatures to reject as duplicates (default: the shipped tasks); each
    accepted task's signature joins it.
    """
    catalogue = catalogue or load_catalogue()
    by_template = _hosts(catalogue, scenes, templates)
    known = set(shipped_signatures()) if known is None else known
    instructions = shipped_instructions(catalogue)
    rng = sampler_rng(seed)
    names = sorted(by_template)
    for _ in range(n):
        s, t, draft = _draw(rng, names, by_template, catalogue, instructions)
        if draft is None:
            yield None, s, t, "duplicate of a shipped or already sampled task"
            continue
        scene = catalogue.scenes[s]
        problem, sig, why = _furnish(rng, draft, scene, catalogue, max_distractors, known)
        if why or problem is None:
            yield None, s, t, why
            continue
        known.add(sig)
        instructions.add((s, draft.language))
        yield SampledTask(task_name(scene, draft.language), s, t, problem), s, t, ""


def _hosts(
    catalogue: Catalogue, scenes: Iterable[str] | None, templates: Iterable[str] | None
) -> dict[str, list[str]]:
    """Per template, the chosen scenes that can host it (so every draw is meaningful)."""
    scene_ids = list(scenes) if scenes else sorted(catalogue.scenes)
    for s in scene_ids:
        if s not in catalogue.scenes:
            raise SamplingError(
                f"unknown scene {s!r}; known: {', '.join(sorted(catalogue.scenes))}", field="scene"
            )
    template_ids = list(templates) if templates else list(TEMPLATES)
    for t in template_ids:
        if t not in TEMPLATES:
            raise SamplingError(
                f"unknown behaviour template {t!r}; known: {', '.join(TEMPLATES)}", field="template"
            )
    probe = np.random.default_rng(0)
    by_template: dict[str, list[str]] = {}
    for s in scene_ids:
        for t in template_ids:
            if instantiate(t, catalogue.scenes[s], catalogue, probe) is not None:
                by_template.setdefault(t, []).append(s)
    if not by_template:
        raise SamplingError("no chosen scene can host any chosen behaviour template")
    return by_template


def _draw(
    rng: np.random.Generator,
    names: list[str],
    by_template: dict[str, list[str]],
    catalogue: Catalogue,
    instructions: set[tuple[str, str]],
) -> tuple[str, str, Draft | None]:
    """A template (uniformly), then a scene that hosts it: keeps the behaviour mix even. One
    instruction per scene layout: drawn again where this one is taken (by a shipped task or an
    earlier draw), so no two tasks differ only in distractors; None after 20 draws."""
    for _redraw in range(20):
        t = names[int(rng.integers(len(names)))]
        s = by_template[t][int(rng.integers(len(by_template[t])))]
        draft = instantiate(t, catalogue.scenes[s], catalogue, rng)
        assert draft is not None
        if (s, draft.language) not in instructions:
            return s, t, draft
    return s, t, None


def _furnish(
    rng: np.random.Generator,
    draft: Draft,
    scene: SceneSpec,
    catalogue: Catalogue,
    max_distractors: int,
    known: set[tuple],
) -> tuple[Problem | None, tuple, str]:
    """The drafted task with distractors and every object placed: (problem, its signature,
    why it was rejected or "")."""
    seen = catalogue.seen_in.get(scene.kind, {})
    pool = [
        c
        for c, spec in sorted(catalogue.objects.items())
        if c not in draft.objects and spec.graspable and spec.radius <= 0.07 and c in seen
    ]
    problem: Problem | None = None
    sig: tuple = ()
    for _attempt in range(DRAWS_PER_TASK):  # other distractors where a draw repeats a task
        # A task about a fixture alone still gets objects around (else every draw is the same).
        k = int(rng.integers(0 if draft.objects else 1, max(max_distractors, 1) + 1))
        distractors = [pool[int(i)] for i in rng.choice(len(pool), size=min(k, len(pool)), replace=False)]
        while True:  # fewer distractors where they do not fit
            categories = [*draft.objects, *distractors]
            radii = [catalogue.objects[c].radius for c in categories]
            order = np.argsort(radii, kind="stable")[::-1]  # big things first
            centres_sorted = _place(rng, scene, [radii[i] for i in order])
            if centres_sorted is not None or not distractors:
                break
            distractors = distractors[:-1]
        if centres_sorted is None:
            return None, (), "placement impossible: the objects do not fit the scene's free regions"
        centres: list[tuple[float, float]] = [(0.0, 0.0)] * len(categories)
        for slot, i in enumerate(order):
            centres[int(i)] = centres_sorted[slot]
        problem = build_problem(draft, scene, catalogue, distractors, centres)
        sig = signature(problem)
        if sig not in known:
            return problem, sig, ""
    return problem, sig, "duplicate of a shipped or already sampled task"


def check_problem(problem: Problem, catalogue: Catalogue | None = None) -> list[str]:
    """Problems with a sampled task (empty when valid): declared names, regions inside their
    tables' boxes, no overlapping footprints, goal predicates that suit their arguments."""
    catalogue = catalogue or load_catalogue()
    issues: list[str] = []
    names = problem.names()
    for atom in [*problem.init, *atoms(problem.goal)]:
        for a in atom.args:
            if a not in names:
                issues.append(f"{atom} names undeclared {a}")
    objects = {o.name: o.category for o in problem.objects}
    fixtures = {f.name: f.category for f in problem.fixtures}
    centres = []
    for atom in problem.init:
        if atom.predicate == "On" and atom.args[0] in objects:
            region = problem.region(atom.args[1])
            x0, y0, x1, y1 = region.ranges[0]
            r = catalogue.objects[objects[atom.args[0]]].radius
            centres.append(((x0 + x1) / 2, (y0 + y1) / 2, r, (x1 - x0) / 2, atom.args[0]))
    for i, (xa, ya, ra, ha, na) in enumerate(centres):
        for xb, yb, rb, hb, nb in centres[i + 1 :]:
            if np.hypot(xa - xb, ya - yb) < ra + rb + ha + hb:
                issues.append(f"{na} and {nb} can overlap")
    for atom in atoms(problem.goal):
        p, args = atom.predicate, atom.args
        if p in ("On", "In"):
            if args[0] not in objects:
                issues.append(f"{atom}: {args[0]} is not a movable object")
            elif not catalogue.objects[objects[args[0]]].graspable:
                issues.append(f"{atom}: {args[0]} cannot be grasped")
            if p == "In" and not any(r.full_name == args[1] for r in problem.regions):
                issues.append(f"{atom}: {args[1]} is not a region")
        elif p in ("Open", "Close"):
            target = args[0]
            found = next((r for r in problem.regions if r.full_name == target), None)
            owner = found.target if found else target
            if owner not in fixtures:
                issues.append(f"{atom}: {target} is not part of a fixture")
        elif p in ("Turnon", "Turnoff") and args[0] not in fixtures:
            issues.append(f"{atom}: {args[0]} is not a fixture")
    return issues
