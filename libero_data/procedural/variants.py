"""Robustness variants of shipped tasks: each differs from its source in one requested way, at
a severity level 1–5 (magnitudes in :mod:`libero_data.perturb.levels`).

- ``layout``: the movable objects start in new places (the scene's object rectangles, at
  least the level's distance away from where the source task puts them; :data:`MOVED` at 1);
- ``distractors``: as many objects the task is not about as the level says (as many as fit);
- ``swap``: the object the task moves is replaced by another of the same kind (a white
  bowl for the black one, ketchup for the tomato sauce), instruction updated; from level 2
  also other objects the goal does not name, up to the level's count;
- ``language``: the instruction is paraphrased (1), then made polite (2), given a context
  phrase (3), synonyms (4) and a trailing clause (5); the BDDL is otherwise unchanged;
- ``camera``, ``robot_init``, ``lighting``, ``texture``, ``noise``: the BDDL is the source's
  with a perturbation record (:mod:`libero_data.perturb`), which the simulator applies.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from libero_data.bddl.model import Atom, Entity, Problem, Region, atoms
from libero_data.perturb.levels import ENV_KINDS, KINDS, LEVELS, magnitude
from libero_data.procedural.catalogue import Catalogue, SceneSpec, load_catalogue
from libero_data.procedural.sampler import GAP, HALF_WIDTH, SampledTask, SamplingError
from libero_data.procedural.templates import HARD_TO_GRASP, display
from libero_data.seeding import variant_level_rng

FIXTURE_CLEARANCE = 0.2  # metres from a fixture's centre to any new object's footprint
MOVED = 0.06  # metres between a moved object's new centre and its source region's centre (level 1)

#: Objects that can stand in for each other.
KIND_GROUPS = (
    ("akita_black_bowl", "white_bowl"),
    ("alphabet_soup", "tomato_sauce"),
    ("bbq_sauce", "ketchup", "salad_dressing"),
    ("milk", "orange_juice"),
    ("butter", "cream_cheese", "chocolate_pudding"),
    ("porcelain_mug", "red_coffee_mug", "white_yellow_mug"),
    ("black_book", "yellow_book"),
)

#: Paraphrase rules, tried in order (the first that applies is used).
PARAPHRASES = (
    (r"^pick up the (.+) and place it in the (.+)$", r"grab the \1 and put it into the \2"),
    (r"^put both the (.+) and the (.+) in the (.+)$", r"place the \1 and the \2 into the \3"),
    (r"^put the (.+) in the (.+) and close it$", r"place the \1 into the \2, then shut it"),
    (r"^turn on the stove and put the (.+) on it$", r"switch the stove on and set the \1 on it"),
    (r"^put the (.+) on top of the (.+)$", r"set the \1 on the top of the \2"),
    (r"^put the (.+) in the (.+)$", r"place the \1 into the \2"),
    (r"^put the (.+) on the (.+)$", r"set the \1 down on the \2"),
    (r"^place the (.+) on the (.+)$", r"put the \1 onto the \2"),
    (r"^pick the (.+) and place it on the (.+)$", r"take the \1 and set it on the \2"),
    (r"^pick up the (.+) and place it on the (.+)$", r"take the \1 and set it on the \2"),
    (r"^stack the (.+) on the (.+)$", r"put the \1 on top of the \2"),
    (r"^open the (.+)$", r"pull the \1 open"),
    (r"^close the (.+)$", r"shut the \1"),
    (r"^turn on the (.+)$", r"switch on the \1"),
    (r"^turn off the (.+)$", r"switch off the \1"),
    (r"^push the (.+) to the (.+)$", r"slide the \1 over to the \2"),
)


def paraphrase(language: str) -> str:
    language = language.strip().lower()
    for pattern, repl in PARAPHRASES:
        if re.match(pattern, language):
            return re.sub(pattern, repl, language)
    return f"please {language}"


#: Language levels 2–5: openings, context phrases, word swaps and closings (chosen by the seed).
POLITE = ("please ", "could you ", "i would like you to ", "go ahead and ")
CONTEXT = (
    "there are several things around so ",
    "take a look at the scene and then ",
    "without touching anything else ",
    "when the arm is ready ",
)
SYNONYMS = {
    "bowl": "dish",
    "basket": "bin",
    "cabinet": "cupboard",
    "mug": "cup",
    "stove": "cooktop",
    "plate": "platter",
    "grab": "grasp",
    "put": "move",
    "place": "move",
    "shut": "close",
}
CLOSINGS = (" and then stop", " as carefully as you can", " and leave the rest as it is", " please")


def reword(language: str, level: int, rng: np.random.Generator) -> str:
    """The instruction reworded as far as ``level`` says (see :data:`~libero_data.perturb.levels.MAGNITUDES`)."""
    m = magnitude("language", level)
    text = paraphrase(language)
    if m["synonyms"]:
        text = " ".join(SYNONYMS.get(word, word) for word in text.split())
    if m["politeness"] and not text.startswith("please "):
        text = POLITE[int(rng.integers(len(POLITE)))] + text
    if m["context_sentence"]:
        text = CONTEXT[int(rng.integers(len(CONTEXT)))] + text
    if m["trailing_clause"]:
        text += CLOSINGS[int(rng.integers(len(CLOSINGS)))]
    return text


def scene_of(task_id: str, catalogue: Catalogue) -> SceneSpec | None:
    for scene in catalogue.scenes.values():
        if task_id in scene.sources:
            return scene
    return None


def _table_starts(problem: Problem, table: str) -> dict[str, Region]:
    """Movable objects that start on the table, with their init region (not used by the goal)."""
    goal_names = {a for atom in atoms(problem.goal) for a in atom.args}
    objects = {o.name for o in problem.objects}
    out = {}
    for atom in problem.init:
        if atom.predicate == "On" and atom.args[0] in objects and atom.args[1].startswith(table + "_"):
            region = problem.region(atom.args[1])
            if atom.args[1] not in goal_names and region.ranges:
                out[atom.args[0]] = region
    return out


def _centre(region: Region) -> tuple[float, float]:
    x0, y0, x1, y1 = region.ranges[0]
    return (x0 + x1) / 2, (y0 + y1) / 2


def _square(name: str, table: str, x: float, y: float) -> Region:
    box = (
        round(x - HALF_WIDTH, 4),
        round(y - HALF_WIDTH, 4),
        round(x + HALF_WIDTH, 4),
        round(y + HALF_WIDTH, 4),
    )
    return Region(name, table, (box,), (0.0, 0.0))


def _replace_starts(problem: Problem, table: str, new: dict[str, tuple[float, float]]) -> Problem:
    """Give each object in ``new`` its own init square at the given centre."""
    regions = list(problem.regions)
    init = []
    for atom in problem.init:
        if atom.predicate == "On" and atom.args[0] in new:
            name = f"{atom.args[0]}_variant_init_region"
            regions.append(_square(name, table, *new[atom.args[0]]))
            init.append(Atom("On", (atom.args[0], f"{table}_{name}")))
        else:
            init.append(atom)
    used = {a for atom in [*init, *atoms(problem.goal)] for a in atom.args}
    regions = [r for r in regions if r.target != table or r.full_name in used]
    return dataclasses.replace(problem, regions=tuple(regions), init=tuple(init))


def _free_centre(
    rng: np.random.Generator,
    scene: SceneSpec,
    radius: float,
    taken: list[tuple[float, float, float]],
    avoid: tuple[float, float] | None = None,
    moved: float = MOVED,
) -> tuple[float, float] | None:
    boxes = np.asarray(scene.boxes, dtype=float)
    # The table area LIBERO uses for objects in this layout, kept clear of the fixtures.
    lo, hi = boxes[:, :2].min(0) - 0.03, boxes[:, 2:].max(0) + 0.03
    fixtures = [((f.ranges[0] + f.ranges[2]) / 2, (f.ranges[1] + f.ranges[3]) / 2) for f in scene.fixtures]
    for _ in range(500):
        c = (float(rng.uniform(lo[0], hi[0])), float(rng.uniform(lo[1], hi[1])))
        if any(np.hypot(c[0] - fx, c[1] - fy) < FIXTURE_CLEARANCE + radius for fx, fy in fixtures):
            continue
        if avoid is not None and np.hypot(c[0] - avoid[0], c[1] - avoid[1]) < moved:
            continue
        if all(np.hypot(c[0] - x, c[1] - y) >= radius + r + GAP + 2 * HALF_WIDTH for x, y, r in taken):
            return c
    return None


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
    from libero_data.perturb.spec import sample

    if kind not in KINDS:
        raise SamplingError(f"unknown variant kind {kind!r}; known: {', '.join(KINDS)}")
    if level not in LEVELS:
        raise SamplingError(f"the level must be 1..5, got {level}")
    language = (language or source.language).strip().lower()
    source = dataclasses.replace(source, language=language)
    if kind == "language":
        return dataclasses.replace(source, language=reword(language, level, rng))
    if kind in ENV_KINDS:
        perturbation = sample(kind, level, int(rng.integers(1 << 31)))
        return dataclasses.replace(source, perturbation=perturbation.to_json())
    catalogue = catalogue or load_catalogue()
    scene = scene_of(task_id, catalogue)
    if scene is None:
        raise SamplingError(f"{task_id} has no scene layout in the catalogue")
    return _SCENE_VARIANTS[kind](_Source(source, task_id, scene, catalogue, level), rng)


@dataclass(frozen=True)
class _Source:
    """The task a scene variant is made from: its problem, id, scene layout and catalogue."""

    problem: Problem
    task_id: str
    scene: SceneSpec
    catalogue: Catalogue
    level: int = 1

    @property
    def category(self) -> dict[str, str]:
        return {o.name: o.category for o in self.problem.objects}

    @property
    def radius(self) -> dict[str, float]:
        objects = self.catalogue.objects
        return {n: objects[c].radius if c in objects else 0.05 for n, c in self.category.items()}


def _layout_variant(src: _Source, rng: np.random.Generator) -> Problem:
    """The objects that start on the table moved to new places, clear of their old ones."""
    source, table, radius = src.problem, src.scene.table, src.radius
    starts = _table_starts(source, table)
    if not starts:
        raise SamplingError(f"{src.task_id}: no object starts on the table")
    fixed = [(*_centre(r), radius[n]) for n, r in _table_starts_all(source, table).items() if n not in starts]
    taken = list(fixed)
    new: dict[str, tuple[float, float]] = {}
    moved = float(magnitude("layout", src.level)["min_move_m"])
    for name in sorted(starts, key=lambda n: -radius[n]):
        c = _free_centre(rng, src.scene, radius[name], taken, avoid=_centre(starts[name]), moved=moved)
        if c is None:
            raise SamplingError(f"{src.task_id}: no new place for {name}")
        new[name] = c
        taken.append((*c, radius[name]))
    return _replace_starts(source, table, new)


def _distractor_variant(src: _Source, rng: np.random.Generator) -> Problem:
    """As many objects as the level says added where they fit, of kinds LIBERO shows in such scenes."""
    source, table, catalogue = src.problem, src.scene.table, src.catalogue
    present = set(src.category.values())
    seen = catalogue.seen_in.get(src.scene.kind, {})
    pool = [
        c
        for c, spec in sorted(catalogue.objects.items())
        if c not in present and spec.graspable and spec.radius <= 0.07 and c in seen
    ]
    k = int(magnitude("distractors", src.level)["count"])
    chosen = [pool[int(i)] for i in rng.choice(len(pool), size=min(k, len(pool)), replace=False)]
    radius = src.radius
    taken = [(*_centre(r), radius[n]) for n, r in _table_starts_all(source, table).items()]
    regions, objects, init = list(source.regions), list(source.objects), list(source.init)
    for extra in chosen:
        spot = _free_centre(rng, src.scene, catalogue.objects[extra].radius, taken)
        if spot is None:
            continue
        name = f"{extra}_1"
        region = f"{extra}_init_region"
        regions.append(_square(region, table, *spot))
        objects.append(Entity(name, extra))
        init.append(Atom("On", (name, f"{table}_{region}")))
        taken.append((*spot, catalogue.objects[extra].radius))
    if len(objects) == len(source.objects):
        raise SamplingError(f"{src.task_id}: no room for a distractor")
    return dataclasses.replace(source, regions=tuple(regions), objects=tuple(objects), init=tuple(init))


def _swap_variant(src: _Source, rng: np.random.Generator) -> Problem:
    """The object the goal moves replaced by another of its kind, the instruction following;
    from level 2 also objects the goal does not name, up to the level's count."""
    source, category, language = src.problem, src.category, src.problem.language
    moved = next(
        (a.args[0] for a in atoms(source.goal) if a.predicate in ("On", "In") and a.args[0] in category), None
    )
    if moved is None:
        raise SamplingError(f"{src.task_id}: the goal moves no object")
    old = category[moved]
    options = _stand_ins(old, set(category.values()))
    words = display(old)
    if not re.search(rf"\b{re.escape(words)}\b", language):
        words = "the " + words.split()[-1]  # "put the bowl ..." for the black bowl
    if not options or not re.search(rf"\b{re.escape(words)}\b", language):
        raise SamplingError(f"{src.task_id}: no object of the same kind can stand in for {old}")
    new_cat = options[int(rng.integers(len(options)))]
    problem = _replace_object(source, moved, new_cat)
    problem = dataclasses.replace(
        problem,
        language=re.sub(
            rf"\b{re.escape(words)}\b",
            ("the " if words.startswith("the ") else "") + display(new_cat),
            language,
            count=1,
        ),
    )
    named = {a for atom in atoms(source.goal) for a in atom.args}
    extra = int(magnitude("swap", src.level)["objects"]) - 1
    for name in sorted(category):
        if extra <= 0:
            break
        present = {o.category for o in problem.objects}
        choices = _stand_ins(category[name], present) if name not in named and name != moved else []
        if choices:
            problem = _replace_object(problem, name, choices[int(rng.integers(len(choices)))])
            extra -= 1
    return problem


def _stand_ins(category: str, present: set[str]) -> list[str]:
    """Categories that can stand in for ``category`` and are not in the scene yet."""
    group = next((g for g in KIND_GROUPS if category in g), ())
    return [c for c in group if c != category and c not in present and c not in HARD_TO_GRASP]


def _replace_object(problem: Problem, old: str, new_category: str) -> Problem:
    """``problem`` with object ``old`` replaced by a ``new_category`` object (regions, init, goal renamed)."""
    new_name = f"{new_category}_1"

    def rename(name: str) -> str:
        if name == old:
            return new_name
        if name.startswith(old + "_"):
            return new_name + name[len(old) :]
        return name

    def swap_atom(a: Atom) -> Atom:
        return Atom(a.predicate, tuple(rename(x) for x in a.args))

    def swap_formula(f: Any) -> Any:
        if isinstance(f, Atom):
            return swap_atom(f)
        if hasattr(f, "terms"):
            return type(f)(tuple(swap_formula(t) for t in f.terms))
        return type(f)(swap_formula(f.term))

    return dataclasses.replace(
        problem,
        regions=tuple(dataclasses.replace(r, target=rename(r.target)) for r in problem.regions),
        objects=tuple(Entity(new_name, new_category) if o.name == old else o for o in problem.objects),
        obj_of_interest=tuple(rename(n) for n in problem.obj_of_interest),
        init=tuple(swap_atom(a) for a in problem.init),
        goal=swap_formula(problem.goal),
    )


#: The variants that change the scene, by kind (``language`` changes the instruction only).
_SCENE_VARIANTS: dict[str, Callable[[_Source, np.random.Generator], Problem]] = {
    "layout": _layout_variant,
    "distractors": _distractor_variant,
    "swap": _swap_variant,
}


def _table_starts_all(problem: Problem, table: str) -> dict[str, Region]:
    objects = {o.name for o in problem.objects}
    out = {}
    for atom in problem.init:
        if atom.predicate == "On" and atom.args[0] in objects and atom.args[1].startswith(table + "_"):
            region = problem.region(atom.args[1])
            if region.ranges:
                out[atom.args[0]] = region
    return out


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
