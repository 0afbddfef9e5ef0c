"""``swap``: the object the task moves is replaced by another of the same kind (a white bowl for
the black one, ketchup for the tomato sauce), the instruction following; from level 2 also other
objects the goal does not name, up to the level's count."""

from __future__ import annotations

import dataclasses
import re
from typing import Any, ClassVar

import numpy as np

from libero_data.bddl.model import Atom, Entity, Problem, atoms
from libero_data.perturb.kinds.base import Kind, VariantSource, register
from libero_data.scenes.sampler import SamplingError
from libero_data.scenes.templates import HARD_TO_GRASP, display

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


@register
class Swap(Kind):
    order = 2
    rewrites_task = True
    needs_layout = True
    keeps_layout = False
    summary = "how many objects are replaced by another of their kind (the moved one first)"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {"objects": (1, 2, 3, 4, 5)}

    def vary(self, src: VariantSource, rng: np.random.Generator) -> Problem:
        """The object the goal moves replaced by another of its kind, the instruction following;
        from level 2 also objects the goal does not name, up to the level's count."""
        source, category, language = src.problem, src.category, src.problem.language
        moved = next(
            (a.args[0] for a in atoms(source.goal) if a.predicate in ("On", "In") and a.args[0] in category),
            None,
        )
        if moved is None:
            raise SamplingError(f"{src.task_id}: the goal moves no object")
        old = category[moved]
        options = stand_ins(old, set(category.values()))
        words = display(old)
        if not re.search(rf"\b{re.escape(words)}\b", language):
            words = "the " + words.split()[-1]  # "put the bowl ..." for the black bowl
        if not options or not re.search(rf"\b{re.escape(words)}\b", language):
            raise SamplingError(f"{src.task_id}: no object of the same kind can stand in for {old}")
        new_cat = options[int(rng.integers(len(options)))]
        problem = replace_object(source, moved, new_cat)
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
        extra = int(self.magnitudes["objects"][src.level - 1]) - 1
        for name in sorted(category):
            if extra <= 0:
                break
            present = {o.category for o in problem.objects}
            choices = stand_ins(category[name], present) if name not in named and name != moved else []
            if choices:
                problem = replace_object(problem, name, choices[int(rng.integers(len(choices)))])
                extra -= 1
        return problem


def stand_ins(category: str, present: set[str]) -> list[str]:
    """Categories that can stand in for ``category`` and are not in the scene yet."""
    group = next((g for g in KIND_GROUPS if category in g), ())
    return [c for c in group if c != category and c not in present and c not in HARD_TO_GRASP]


def replace_object(problem: Problem, old: str, new_category: str) -> Problem:
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
