"""A LIBERO-Plus task's added objects made known to LIBERO before it builds the scene.

Their BDDL files name the added objects by categories LIBERO's object registry lacks
(``canned_food__1``); each is a model file in their assets folder
(``new_objects/<name>/<id>/usd/MJCF/<id>.xml``), loaded as a free-jointed object like LIBERO's
scanned ones. Two things differ from LIBERO's own objects, both as their object classes do:

- their model files put the body named ``object`` right under the world body, where robosuite
  looks one level deeper; the model is read either way;
- their placement sampler composes one rotation per axis (their ``self.rotation`` dict; all of
  theirs are fixed angles). LIBERO's sampler takes one axis, so the composed rotation is given to
  it as the single-axis rotation it equals (refused where it equals none). Stored init states carry
  the objects' poses: the sampler only matters for starts drawn by LIBERO's sampler.

Registration is for the process (LIBERO's registry is a module dictionary); a category already
known is left as it is, as their registry does.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from libero_data.errors import FileFormatError


def register_objects(objects: dict[str, dict[str, Any]]) -> None:
    """Register each added object (category -> ``{"model": path, "rotation": [[axis, low, high],
    ...]}``) in LIBERO's object registry, unless the category is known."""
    from libero.libero.envs.base_object import OBJECTS_DICT

    for category, spec in objects.items():
        if category not in OBJECTS_DICT:
            OBJECTS_DICT[category] = _object_class(category, str(spec["model"]), _rotation(spec["rotation"]))


def _rotation(axes: Sequence[Sequence[Any]]) -> tuple[tuple[float, float], str]:
    """LIBERO's (rotation, rotation_axis) for their per-axis rotations: a range about one axis
    kept as it is; fixed angles about several axes composed (each turn applied after the ones
    before, as their sampler multiplies them) and given as the one-axis turn they make."""
    if not axes:
        return (0.0, 2 * math.pi), "z"  # any angle about z
    if len(axes) == 1:
        axis, low, high = axes[0]
        return (float(low), float(high)), str(axis)
    if any(float(low) != float(high) for _axis, low, high in axes):
        raise FileFormatError(
            f"LIBERO-Plus: an object turns by ranges about several axes ({axes}); not supported"
        )
    q = np.array([1.0, 0.0, 0.0, 0.0])  # w, x, y, z
    for axis, angle, _high in axes:
        q = _multiply(_about(str(axis), float(angle)), q)
    if q[0] < 0:
        q = -q
    angle = 2 * math.atan2(float(np.linalg.norm(q[1:])), float(q[0]))
    if angle < 1e-9:
        return (0.0, 0.0), "z"
    direction = q[1:] / np.linalg.norm(q[1:])
    for index, axis in enumerate("xyz"):
        if abs(abs(direction[index]) - 1.0) < 1e-9:
            signed = angle if direction[index] > 0 else -angle
            return (signed, signed), axis
    raise FileFormatError(
        f"LIBERO-Plus: an object's rotation {axes} is no turn about x, y or z; not supported"
    )


def _about(axis: str, angle: float) -> np.ndarray:
    q = np.zeros(4)
    q[0] = math.cos(angle / 2)
    q[1 + "xyz".index(axis)] = math.sin(angle / 2)
    return q


def _multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


@functools.cache
def _base() -> Any:
    """robosuite's XML object that reads a model whose ``object`` body is under the world body
    itself as well as one level down (made on first use: robosuite loads lazily)."""
    import xml.etree.ElementTree as ET

    from robosuite.models.objects import MujocoXMLObject

    xml_object: Any = MujocoXMLObject

    class PlusXMLObject(xml_object):
        worldbody: Any  # robosuite's parsed <worldbody>

        def _get_object_subtree(self) -> Any:
            real = self.worldbody
            top = real.find("./body[@name='object']")
            if real.find("./body/body[@name='object']") is not None or top is None:
                return super()._get_object_subtree()
            # robosuite copies the body it finds: show it one level down, in a holder body
            view = ET.Element("worldbody")
            ET.SubElement(view, "body").append(top)
            self.worldbody = view
            try:
                return super()._get_object_subtree()
            finally:
                self.worldbody = real

    return PlusXMLObject


def _object_class(category: str, model: str, rotation: tuple[tuple[float, float], str]) -> type:
    """A class LIBERO's problem classes instantiate as ``cls(name=...)`` for one added category."""
    base: Any = _base()
    angles, axis = rotation

    class PlusObject(base):
        def __init__(self, name: str = category, obj_name: str = category) -> None:
            super().__init__(
                model,
                name=name,
                joints=[{"type": "free", "damping": "0.0005"}],
                obj_type="all",
                duplicate_collision_geoms=False,
            )
            self.category_name = category
            self.rotation = angles
            self.rotation_axis = axis
            self.object_properties: dict[str, Any] = {"vis_site_names": {}}

    PlusObject.__name__ = f"PlusObject_{category}"
    return PlusObject
