"""Each robustness variant differs from its source task in exactly the requested way."""

from __future__ import annotations

import numpy as np
import pytest

from libero_data.bddl import parse
from libero_data.bddl.model import atoms
from libero_data.bddl.writer import write
from libero_data.perturb.kinds.language import paraphrase
from libero_data.perturb.kinds.placement import MOVED, scene_of
from libero_data.procedural.variants import make_variant, variant_tasks
from libero_data.scenes.catalogue import load_catalogue
from libero_data.scenes.sampler import SamplingError, check_problem
from libero_data.tasks import get_task


def variant(ref: str, kind: str, seed: int = 0):
    task = get_task(ref)
    rng = np.random.default_rng(seed)
    return task, make_variant(task.problem, task.id, kind, rng, language=task.language)


def starts(problem, table: str) -> dict[str, tuple[float, float]]:
    out = {}
    for a in problem.init:
        if (
            a.predicate == "On"
            and a.args[1].startswith(table + "_")
            and a.args[0] in {o.name for o in problem.objects}
        ):
            x0, y0, x1, y1 = problem.region(a.args[1]).ranges[0]
            out[a.args[0]] = ((x0 + x1) / 2, (y0 + y1) / 2)
    return out


def test_layout_moves_only_where_objects_start() -> None:
    task, v = variant("libero_spatial/0", "layout")
    src = task.problem
    assert (v.objects, v.fixtures, v.goal, v.language) == (src.objects, src.fixtures, src.goal, task.language)
    scene = scene_of(task.id, load_catalogue())
    assert scene is not None
    table = scene.table
    before, after = starts(src, table), starts(v, table)
    moved = [n for n in after if np.hypot(after[n][0] - before[n][0], after[n][1] - before[n][1]) >= MOVED]
    assert moved, "no object was moved"
    for name in after:  # an object either kept its place (it is on the goal's region) or moved far
        d = np.hypot(after[name][0] - before[name][0], after[name][1] - before[name][1])
        assert d == 0 or d >= MOVED
    # Predicates other than the starting places are unchanged.
    assert [a for a in v.init if not a.args[1].startswith(table + "_")] == [
        a for a in src.init if not a.args[1].startswith(table + "_")
    ]
    assert parse(write(v)) == v


def test_distractors_only_add_objects() -> None:
    task, v = variant("libero_spatial/0", "distractors")
    src = task.problem
    added = v.objects[len(src.objects) :]
    assert v.objects[: len(src.objects)] == src.objects and 1 <= len(added) <= 2
    assert {o.category for o in added}.isdisjoint({o.category for o in src.objects})
    assert v.goal == src.goal and v.language == task.language and v.fixtures == src.fixtures
    assert set(src.init) <= set(v.init) and len(v.init) == len(src.init) + len(added)
    # The added objects overlap nothing (the shipped layout itself is LIBERO's business).
    assert not [i for i in check_problem(v) if any(o.name in i for o in added)]


def test_swap_replaces_the_moved_object_with_one_of_its_kind() -> None:
    task, v = variant("libero_10/1", "swap")  # put both the cream cheese box and the butter in the basket
    src = task.problem
    old = {o.category for o in src.objects} - {o.category for o in v.objects}
    new = {o.category for o in v.objects} - {o.category for o in src.objects}
    assert old == {"cream_cheese"} and len(new) == 1 and new <= {"butter", "chocolate_pudding"} - {"butter"}
    assert len(v.objects) == len(src.objects)
    assert [a.predicate for a in atoms(v.goal)] == [a.predicate for a in atoms(src.goal)]
    assert v.language == task.language.replace("cream cheese", "chocolate pudding")
    assert v.problem == src.problem and v.fixtures == src.fixtures


def test_language_changes_only_the_instruction() -> None:
    task, v = variant("libero_goal/0", "language")
    assert v.language != task.language and v.language == paraphrase(task.language)
    from dataclasses import replace

    assert replace(v, language=task.language) == replace(task.problem, language=task.language)
    assert paraphrase("turn on the stove") == "switch on the stove"
    assert paraphrase("put the bowl on the plate") == "set the bowl down on the plate"


def test_variants_are_seeded_and_reasons_are_given() -> None:
    a = [write(t.problem) if t else why for t, *_, why in variant_tasks("libero_spatial", ["layout"], 3)]
    b = [write(t.problem) if t else why for t, *_, why in variant_tasks("libero_spatial", ["layout"], 3)]
    assert a == b
    with pytest.raises(SamplingError, match="unknown variant kind"):
        list(variant_tasks("libero_spatial", ["upside_down"], 0))
    out = list(
        variant_tasks("libero_goal", ["swap"], 0, tasks=["1"])
    )  # put the bowl on the stove: a wine bottle? no
    assert all(t is None or t.template == "variant:swap" for t, *_ in out)
    assert all(t is not None or why for t, *_, why in out)
