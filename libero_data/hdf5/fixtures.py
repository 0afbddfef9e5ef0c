"""A LIBERO file's scene in our simulator: its task found from its BDDL, its fixtures placed.

LIBERO samples where fixtures (a cabinet, a stove) stand at every reset, and its stored init
states hold only what moves, so a demonstration's states mean the scene they were recorded in
only with the fixtures where they stood then. Each demonstration's ``model_file`` (the scene's
MuJoCo XML) records that: :func:`fixture_poses` reads each fixture's root body pose from it and
:func:`place_fixtures` puts our scene's fixtures there (XML keeps 6 significant digits: the
fixtures land within a micrometre of where they stood).
"""

from __future__ import annotations

import functools
import re
import xml.etree.ElementTree as ET
from typing import Any

import numpy as np

from libero_data.errors import DatasetError, first_line

#: The suites a file's task is looked up in (LIBERO's own), in this order.
LOOKUP_SUITES = ("libero_spatial", "libero_object", "libero_goal", "libero_10", "libero_90")


def normal_bddl(text: str) -> str:
    """BDDL text with comments dropped and white space collapsed (how two copies are compared)."""
    lines = [line.split(";", 1)[0] for line in text.splitlines()]
    return re.sub(r"\s+", " ", " ".join(lines)).strip()


@functools.cache
def _bddl_index() -> dict[str, list[tuple[str, int]]]:
    from libero_data.tasks import get_suite

    index: dict[str, list[tuple[str, int]]] = {}
    for name in LOOKUP_SUITES:
        for task in get_suite(name).tasks:
            index.setdefault(normal_bddl(task.bddl_path.read_text()), []).append((name, task.index))
    return index


def registry_task(bddl_content: str, bddl_file_name: str) -> Any | None:
    """The registry task whose BDDL is the file's (its ``bddl_file_name`` settles ties between
    suites), or None when it is none of LIBERO's tasks here."""
    from libero_data.tasks import get_suite

    matches = _bddl_index().get(normal_bddl(bddl_content), [])
    if not matches:
        return None
    parts = bddl_file_name.replace("\\", "/").split("/")
    preferred = [m for m in matches if m[0] in parts]
    suite, index = (preferred or matches)[0]
    return get_suite(suite).task(index)


def fixture_poses(model_xml: str, env: Any, where: str) -> dict[str, list[float]]:
    """Each fixture's root body pose in ``model_xml``: name -> ``[x, y, z, qw, qx, qy, qz]``
    (MuJoCo's order). A fixture the XML does not place keeps the pose our reset gives it."""
    import mujoco

    try:
        root = ET.fromstring(model_xml)
    except ET.ParseError as exc:
        raise DatasetError(f"{where}: its model_file is not MuJoCo XML ({first_line(exc)})") from None
    bodies = {b.get("name"): b for b in root.iter("body")}
    model = env.sim.model._model
    poses: dict[str, list[float]] = {}
    for name in env.fixture_names:
        body_id = env.raw.obj_body_id.get(name)
        if body_id is None:
            continue  # the table: not a body of its own
        element = bodies.get(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body_id))
        if element is None:
            continue
        pos = _floats(element.get("pos", "0 0 0"), 3, where)
        quat = _floats(element.get("quat", "1 0 0 0"), 4, where)
        poses[name] = [*pos, *quat]
    return poses


def place_fixtures(env: Any, poses: dict[str, list[float]]) -> None:
    """Put the scene's fixtures at ``poses`` (after a reset, before restoring a state)."""
    model = env.sim.model._model
    for name, pose in poses.items():
        body_id = env.raw.obj_body_id[name]
        model.body_pos[body_id] = np.asarray(pose[:3], dtype=np.float64)
        model.body_quat[body_id] = np.asarray(pose[3:7], dtype=np.float64)
    env.sim.forward()


def _floats(text: str, n: int, where: str) -> list[float]:
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) != n:
        raise DatasetError(f"{where}: its model_file has a body pose {text!r} that is not {n} numbers")
    return values
