"""What procedural tasks are made of: scene layouts and objects, as data.

``catalogue.json`` beside this module is built from the 130 shipped BDDL files and the
shipped assets by :mod:`libero_data.procedural.catalogue_build`
(``python -m libero_data.procedural.catalogue_build``, which needs the simulator):

- a **scene** is one fixture layout LIBERO uses: the problem class (kitchen, living room,
  study, tabletop, floor), the table fixture, the other fixtures with their placement
  regions and the regions they carry (drawers, cook region, ...), and the rectangles where
  LIBERO's own tasks put movable objects in that layout (new objects are placed there, so
  they never start inside a fixture);
- an **object** is an asset category with its measured footprint (radius and height, from
  the simulator's collision geometry), whether the expert can grasp it, and the regions it
  carries when it is a container (a basket's ``contain_region``).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

_HERE = Path(__file__).parent
CATALOGUE_PATH = _HERE / "catalogue.json"

#: Problem classes and the short names scenes are called by.
SCENE_KINDS = {
    "LIBERO_Kitchen_Tabletop_Manipulation": "kitchen",
    "LIBERO_Living_Room_Tabletop_Manipulation": "living_room",
    "LIBERO_Study_Tabletop_Manipulation": "study",
    "LIBERO_Tabletop_Manipulation": "tabletop",
    "LIBERO_Floor_Manipulation": "floor",
}
#: Flat objects that are pushed, never grasped (the expert's planner agrees).
NOT_GRASPABLE = {"plate"}


@dataclass(frozen=True)
class FixtureSpec:
    name: str
    category: str
    ranges: tuple[float, float, float, float]
    yaw: tuple[float, float] | None
    regions: tuple[str, ...]  # regions the fixture carries (``top_region``, ``cook_region``, ...)
    drawers: tuple[str, ...]  # of those, drawers this layout's shipped tasks open or close
    closable: tuple[str, ...]  # of those, the ones a shipped task of this layout closes
    door: tuple[str, ...]  # the fixture itself opens (a microwave): what this layout's tasks do with it
    knob: bool  # it turns on and off (a stove)


@dataclass(frozen=True)
class SceneSpec:
    id: str
    kind: str
    problem: str
    table: str
    table_category: str
    fixtures: tuple[FixtureSpec, ...]
    boxes: tuple[tuple[float, float, float, float], ...]  # where movable objects may start
    sources: tuple[str, ...]  # shipped tasks with this layout


@dataclass(frozen=True)
class ObjectSpec:
    category: str
    radius: float
    height: float
    graspable: bool
    regions: tuple[str, ...]  # regions the object carries (containers)


@dataclass(frozen=True)
class Catalogue:
    scenes: dict[str, SceneSpec]
    objects: dict[str, ObjectSpec]
    seen_in: dict[str, dict[str, list[str]]]  # scene kind -> object category -> shipped tasks


def _scene_from_json(key: str, d: dict[str, Any]) -> SceneSpec:
    fixtures = tuple(
        FixtureSpec(
            f["name"],
            f["category"],
            tuple(f["ranges"]),
            tuple(f["yaw"]) if f["yaw"] is not None else None,
            tuple(f["regions"]),
            tuple(f["drawers"]),
            tuple(f["closable"]),
            tuple(f["door"]),
            bool(f["knob"]),
        )
        for f in d["fixtures"]
    )
    return SceneSpec(
        key,
        d["kind"],
        d["problem"],
        d["table"],
        d["table_category"],
        fixtures,
        tuple(tuple(b) for b in d["boxes"]),
        tuple(d["sources"]),
    )


@functools.cache
def load_catalogue(path: str | None = None) -> Catalogue:
    data = json.loads(Path(path or CATALOGUE_PATH).read_text())
    scenes = {k: _scene_from_json(k, v) for k, v in data["scenes"].items()}
    objects = {
        k: ObjectSpec(k, float(v["radius"]), float(v["height"]), bool(v["graspable"]), tuple(v["regions"]))
        for k, v in data["objects"].items()
    }
    return Catalogue(scenes, objects, data["seen_in"])
