"""What every robustness kind is, and the registry that finds them.

A kind is one module of :mod:`libero_data.perturb.kinds` holding one :class:`Kind` subclass,
registered with ``@register`` under its module's name: its magnitudes at levels 1–5, how a level is
drawn (``sample`` for kinds the simulator applies, ``vary`` for kinds that rewrite the task's
BDDL) and, for the former, how the simulator applies it (``apply_scene`` once the scene is built,
``start_robot`` after each reset, ``observe`` on each observation). ``keeps_layout`` says which
start its contact-sheet frame uses (the source's first stored state, or the sampler's).

To add a kind, copy the module of the kind whose hook is like its own (``lighting.py``:
``apply_scene``; ``robot_init.py``: ``start_robot``; ``noise.py``: ``observe``; ``language.py``:
``vary``), give it the next ``order`` and a test (ARCHITECTURE.md, "How to add…", states each
hook's contract).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from libero_data.registry import Registry

if TYPE_CHECKING:
    from libero_data.bddl.model import Problem
    from libero_data.scenes.catalogue import Catalogue, SceneSpec


class Drawn(Protocol):
    """What a kind's hooks read of a drawn perturbation (:class:`~libero_data.perturb.spec.Perturbation`)."""

    @property
    def seed(self) -> int: ...

    @property
    def params(self) -> dict[str, Any]: ...


class Kind:
    """One robustness kind (see the module docstring)."""

    #: the kind's place in the list of kinds (tables, defaults; the seeds of drawn values)
    order: ClassVar[int]
    #: True: rewrites the task's BDDL (scene or instruction); False: a perturbation record
    #: the simulator applies to the scene, the arm's start or the observations
    rewrites_task: ClassVar[bool] = False
    #: the scene kinds that place objects need the task's layout from the catalogue
    needs_layout: ClassVar[bool] = False
    #: the contact sheet starts its frames from the source's first stored state
    keeps_layout: ClassVar[bool] = True
    #: what a level sets, in a few words (docs)
    summary: ClassVar[str]
    #: per parameter (units in the name): the magnitude at levels 1..5
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]]

    def __init__(self, name: str) -> None:
        self.name = name

    # -- kinds that rewrite the task ------------------------------------------------------------
    def vary(self, src: VariantSource, rng: np.random.Generator) -> Problem:
        """The variant of ``src.problem`` at ``src.level`` (raise SamplingError where none fits)."""
        raise NotImplementedError(f"{self.name} is applied by the simulator, not written into the task")

    # -- kinds the simulator applies -------------------------------------------------------------
    def sample(self, m: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
        """The concrete values drawn for one variant, from the level's magnitudes ``m``."""
        raise NotImplementedError(f"{self.name} rewrites the task; it draws no perturbation record")

    def prepare_build(self, p: Drawn) -> None:
        """Make ready what building the scene needs (e.g. object models LIBERO does not know);
        once, before the scene is built."""

    def apply_scene(self, raw: Any, p: Drawn) -> None:
        """Change the built scene of ``raw`` (robosuite's environment); once per build."""

    def start_robot(self, raw: Any, p: Drawn, reset_seed: int) -> None:
        """Change where the arm starts; after each reset."""

    def observe(self, obs: dict[str, Any], p: Drawn, cameras: tuple[str, ...]) -> None:
        """Change an observation in place (its ``sim_state`` stays clean)."""


#: Every kind, by name (filled by the kind modules when :mod:`libero_data.perturb.kinds` loads them).
REGISTRY: Registry[Kind] = Registry("robustness kind")


def register(cls: type[Kind]) -> type[Kind]:
    """Class decorator: register one instance of ``cls`` under its module's name."""
    name = cls.__module__.rpartition(".")[2]
    REGISTRY.register(name)(cls(name))
    return cls


@dataclass(frozen=True)
class VariantSource:
    """The task a variant is made from: its problem, id, level, and (for kinds that place
    objects) its scene layout and the catalogue."""

    problem: Problem
    task_id: str
    level: int
    scene: SceneSpec | None = None
    catalogue: Catalogue | None = None

    @property
    def category(self) -> dict[str, str]:
        return {o.name: o.category for o in self.problem.objects}

    @property
    def radius(self) -> dict[str, float]:
        objects = self.catalogue.objects if self.catalogue is not None else {}
        return {n: objects[c].radius if c in objects else 0.05 for n, c in self.category.items()}


def sign(rng: np.random.Generator) -> float:
    """-1 or +1, drawn."""
    return float(rng.choice((-1.0, 1.0)))


def rotation(axis: np.ndarray, degrees: float) -> np.ndarray:
    """The rotation matrix of ``degrees`` about ``axis`` (Rodrigues)."""
    axis = axis / np.linalg.norm(axis)
    a = np.deg2rad(degrees)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(a) * k + (1 - np.cos(a)) * (k @ k)


def tint(hue: float, strength: float, brightness: float = 0.0) -> list[float]:
    """An RGB multiplier: white moved ``strength`` toward the colour of ``hue``, scaled by 1 + brightness."""
    import colorsys

    r, g, b = colorsys.hsv_to_rgb(hue, 1.0, 1.0)
    return [round((1.0 - strength + strength * c) * (1.0 + brightness), 4) for c in (r, g, b)]
