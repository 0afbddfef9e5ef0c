"""Typed, immutable model of a LIBERO BDDL problem.

A LIBERO problem names a scene (``problem``), a language instruction, placement regions
attached to fixtures or objects, the fixtures and movable objects with their categories,
the objects of interest, the initial predicates (where things start) and the goal, a
conjunction of predicates (``Or``/``Not`` are modelled too, although no shipped task uses
them).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

#: Known predicates: canonical spelling (as LIBERO's files write it) and arity.
#: LIBERO matches predicate names case-insensitively; so does our parser.
PREDICATES: dict[str, int] = {
    "On": 2,
    "In": 2,
    "Open": 1,
    "Close": 1,
    "Turnon": 1,
    "Turnoff": 1,
    "Up": 1,
    "True": 0,
    "False": 0,
}
CANONICAL_PREDICATE: dict[str, str] = {name.lower(): name for name in PREDICATES}


@dataclass(frozen=True)
class Region:
    """A named placement region attached to a fixture or object (its ``target``).

    ``ranges`` are axis-aligned rectangles ``(x_min, y_min, x_max, y_max)`` in the target's
    frame; sites such as ``top_region`` of a cabinet have none. Predicates refer to a region
    by its full name ``<target>_<name>``.
    """

    name: str
    target: str
    ranges: tuple[tuple[float, float, float, float], ...] = ()
    yaw_rotation: tuple[float, float] | None = None
    rgba: tuple[float, float, float, float] | None = None

    @property
    def full_name(self) -> str:
        return f"{self.target}_{self.name}"


@dataclass(frozen=True)
class Entity:
    """A fixture or movable object: instance name and asset category."""

    name: str
    category: str


@dataclass(frozen=True)
class Atom:
    """A predicate applied to named things, e.g. ``On(bowl_1, plate_1)``."""

    predicate: str
    args: tuple[str, ...]

    def __str__(self) -> str:
        return f"({' '.join((self.predicate, *self.args))})"


@dataclass(frozen=True)
class And:
    terms: tuple[Formula, ...]


@dataclass(frozen=True)
class Or:
    terms: tuple[Formula, ...]


@dataclass(frozen=True)
class Not:
    term: Formula


type Formula = Atom | And | Or | Not


def atoms(formula: Formula) -> Iterator[Atom]:
    """All atoms of a formula, depth first, in written order."""
    if isinstance(formula, Atom):
        yield formula
    elif isinstance(formula, Not):
        yield from atoms(formula.term)
    else:
        for term in formula.terms:
            yield from atoms(term)


@dataclass(frozen=True)
class Problem:
    """One LIBERO task as written in its BDDL file."""

    problem: str
    language: str
    regions: tuple[Region, ...]
    fixtures: tuple[Entity, ...]
    objects: tuple[Entity, ...]
    obj_of_interest: tuple[str, ...]
    init: tuple[Atom, ...]
    goal: Formula
    domain: str = "robosuite"
    #: A robustness perturbation of the scene (camera, lighting, ...), as canonical JSON;
    #: written as a ``; libero-data perturbation: {...}`` comment line, which LIBERO's own
    #: parser skips (libero_data.perturb).
    perturbation: str = ""

    @property
    def scene(self) -> str:
        """The LIBERO problem class, e.g. ``LIBERO_Kitchen_Tabletop_Manipulation``."""
        return self.problem

    @property
    def entities(self) -> tuple[Entity, ...]:
        return self.fixtures + self.objects

    def category_of(self, name: str) -> str:
        for entity in self.entities:
            if entity.name == name:
                return entity.category
        raise KeyError(name)

    def region(self, full_name: str) -> Region:
        for region in self.regions:
            if region.full_name == full_name:
                return region
        raise KeyError(full_name)

    def names(self) -> set[str]:
        """Every name a predicate may refer to: fixtures, objects and regions."""
        return {e.name for e in self.entities} | {r.full_name for r in self.regions}

    def goal_atoms(self) -> list[Atom]:
        return list(atoms(self.goal))
