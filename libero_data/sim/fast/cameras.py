"""The cameras mounted on a body (the wrist camera), and the meshes they carry.

``fast`` treats a camera on a body differently from one fixed to the world: it is drawn without
MuJoCo's mirror pass (:func:`mounted_cameras`), and the meshes on its body and below it (the
gripper, which fills much of the wrist image) are drawn whole, never simplified
(:func:`camera_meshes`).
"""

from __future__ import annotations

from typing import Any

import numpy as np


def mounted_cameras(model: Any, camera_ids: list[int]) -> frozenset[int]:
    """The cameras on a body (the wrist camera); the others are fixed to the world.

    ``fast`` draws the mounted ones without MuJoCo's mirror pass. Looking down along the gripper
    at a reflective surface, such a camera sees in it mostly the mirror image of what stands
    between them, hidden behind the thing itself. Dropping the pass, which draws every geom a
    second time, therefore changes the wrist image little and saves much of its draw where a
    reflective surface is in the scene (benchmarks/RESULTS.md, Fast rendering: the column "wrist
    draw, with its mirror pass"). From the fixed cameras the reflection shows, so they keep it.
    """
    return frozenset(c for c in camera_ids if int(model.cam_bodyid[c]) != 0)


def camera_meshes(model: Any, camera_ids: list[int]) -> set[int]:
    """Meshes on the bodies of cameras mounted on a body (not the world), and on their descendants."""
    import mujoco

    roots = {int(model.cam_bodyid[c]) for c in mounted_cameras(model, camera_ids)}
    if not roots:
        return set()
    inside = np.zeros(model.nbody, dtype=bool)
    for body in range(1, model.nbody):  # parents come before children in MuJoCo's body order
        inside[body] = body in roots or bool(inside[model.body_parentid[body]])
    is_mesh = model.geom_type == mujoco.mjtGeom.mjGEOM_MESH
    return {int(i) for i in model.geom_dataid[is_mesh & inside[model.geom_bodyid]]}
