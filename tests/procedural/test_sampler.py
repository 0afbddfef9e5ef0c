"""Sampled tasks are valid LIBERO tasks, reproducible, and never repeat a shipped one."""

from __future__ import annotations

import pytest

from libero_data.bddl import parse
from libero_data.bddl.model import atoms
from libero_data.bddl.writer import write
from libero_data.scenes.catalogue import load_catalogue
from libero_data.scenes.sampler import (
    SamplingError,
    check_problem,
    sample_tasks,
    shipped_signatures,
    signature,
)
from libero_data.scenes.templates import TEMPLATES
from libero_data.tasks import get_task


@pytest.fixture(scope="module")
def drawn() -> list:
    return list(sample_tasks(60, seed=7))


def test_catalogue_covers_the_shipped_scenes_and_objects() -> None:
    cat = load_catalogue()
    kinds = {s.kind for s in cat.scenes.values()}
    assert kinds == {"kitchen", "living_room", "study", "tabletop", "floor"}
    assert cat.objects["basket"].regions == ("contain_region",)
    assert not cat.objects["plate"].graspable and cat.objects["akita_black_bowl"].graspable
    # Drawers are the ones the layout's own shipped tasks open or close.
    drawers = {
        d
        for s in cat.scenes.values()
        for f in s.fixtures
        if f.category == "wooden_cabinet"
        for d in f.drawers
    }
    assert drawers == {"top_region", "middle_region", "bottom_region"}
    assert cat.scenes["tabletop_flat_stove_wooden_cabinet"].fixtures[0].drawers == ("top_region",)
    assert all(0.01 < o.radius < 0.2 for o in cat.objects.values())


def test_sampled_tasks_are_valid(drawn: list) -> None:
    kept = [t for t, *_ in drawn if t is not None]
    assert len(kept) >= 45
    for task in kept:
        assert check_problem(task.problem) == [], task.name
        assert parse(write(task.problem)) == task.problem  # LIBERO-format BDDL, round trip
        assert task.problem.language in task.name.replace("_", " ")


def test_check_problem_finds_errors() -> None:
    import dataclasses

    from libero_data.bddl.model import And, Atom

    task = next(t for t, *_ in sample_tasks(20, seed=3) if t is not None and len(t.problem.objects) > 1)
    p = task.problem
    obj = p.objects[0].name
    bad_goal = dataclasses.replace(p, goal=And((Atom("Turnon", (obj,)),)))
    assert any("is not a fixture" in issue for issue in check_problem(bad_goal))
    # Two objects starting in the same square overlap.
    twin = p.objects[1].name
    twin_region = next(a.args[1] for a in p.init if a.args[0] == twin)
    others = [a for a in p.init if a.args[0] != obj]
    overlapped = dataclasses.replace(p, init=(*others, Atom("On", (obj, twin_region))))
    assert any("can overlap" in issue for issue in check_problem(overlapped))
    undeclared = dataclasses.replace(p, goal=And((Atom("On", (obj, "nowhere_region")),)))
    assert any("undeclared nowhere_region" in issue for issue in check_problem(undeclared))


def test_same_seed_same_tasks() -> None:
    a = [write(t.problem) if t else why for t, _, _, why in sample_tasks(15, seed=11)]
    b = [write(t.problem) if t else why for t, _, _, why in sample_tasks(15, seed=11)]
    c = [write(t.problem) if t else why for t, _, _, why in sample_tasks(15, seed=12)]
    assert a == b
    assert a != c


def test_no_duplicates_of_each_other_or_of_shipped_tasks(drawn: list) -> None:
    sigs = [signature(t.problem) for t, *_ in drawn if t is not None]
    assert len(set(sigs)) == len(sigs)
    assert not set(sigs) & shipped_signatures()


def test_known_tasks_are_never_drawn_again() -> None:
    first = [t for t, *_ in sample_tasks(10, seed=5) if t is not None]
    known_first = {signature(t.problem) for t in first}
    known = shipped_signatures() | known_first
    again = list(sample_tasks(10, seed=5, known=known))  # the same draws, now all known
    kept = [t for t, *_ in again if t is not None]
    assert not {signature(t.problem) for t in kept} & known_first  # redrawn or rejected
    assert all(t is not None or "duplicate" in why or "placement" in why for t, *_, why in again)
    # A shipped task's signature is found among the shipped ones.
    assert signature(get_task("libero_goal/0").problem) in shipped_signatures()


def test_a_template_that_only_repeats_shipped_tasks_is_rejected() -> None:
    from libero_data.scenes.catalogue import load_catalogue

    cat = load_catalogue()
    # Every floor task would be known: the sampler gives up after a few draws and says why.
    out = list(sample_tasks(3, seed=0, scenes=["floor"], templates=["put_in_container"], known=_Everything()))
    assert [why for *_, why in out] == ["duplicate of a shipped or already sampled task"] * 3
    assert "floor" in cat.scenes


class _Everything(set):
    def __contains__(self, item: object) -> bool:
        return True


def test_templates_produce_their_predicates(drawn: list) -> None:
    for task, _scene, template, _ in drawn:
        if task is None:
            continue
        predicates = tuple(a.predicate for a in atoms(task.problem.goal))
        assert sorted(predicates) == sorted(TEMPLATES[template].goal), task.name
        init = {a.predicate for a in task.problem.init} - {"On"}
        assert init == set(TEMPLATES[template].init), task.name


def test_scene_and_template_choice() -> None:
    tasks = [t for t, *_ in sample_tasks(8, seed=1, templates=["turn_on_stove"]) if t is not None]
    assert tasks and all(t.template == "turn_on_stove" for t in tasks)
    with pytest.raises(SamplingError, match="unknown scene"):
        list(sample_tasks(1, seed=0, scenes=["moon_base"]))
    with pytest.raises(SamplingError, match="no chosen scene can host"):
        list(sample_tasks(1, seed=0, scenes=["living_room"], templates=["turn_on_stove"]))


def test_one_instruction_per_scene_and_unique_names(drawn: list) -> None:
    from libero_data.scenes.catalogue import load_catalogue
    from libero_data.scenes.sampler import shipped_instructions

    kept = [t for t, *_ in drawn if t is not None]
    pairs = [(t.scene, t.language) for t in kept]
    assert len(set(pairs)) == len(pairs)
    assert len({t.name for t in kept}) == len(kept)
    assert not set(pairs) & shipped_instructions(load_catalogue())
