"""Meshes the fixed cameras only see from afar, simplified to their size on the screen.

``fast`` simplifies every drawn mesh to within :attr:`MeshSettings.max_error` (0.5 mm): what
the wrist camera needs a few centimetres from a surface. The fixed cameras (agentview) never
come that close to what cannot move: the robot's base link and pedestal stand ~1.4 m from
agentview and the kitchen and living-room backgrounds 2-3 m, where 0.5 mm is about a
hundredth of a pixel at 128x128. For the fixed cameras, each such mesh is simplified to the
coarsest of :data:`LEVELS` that stays within :data:`SCREEN_ERROR_PX` of a pixel at its vertex
nearest to any of them; meshes that move, or that LIBERO places anew at every reset (fixtures:
a cabinet, a stove), keep the 0.5 mm copies, so the choice depends on the model alone and is
the same in every process whatever it reset to first.

What cannot move, from the model alone: geoms welded to the world (``body_weldid == 0``) that
belong to the world body itself (a scene's background) or to the robot that carries a mounted
camera (its fixed base link and pedestal). Fixtures are bodies of their own under the world.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from libero_data.sim.fast.cameras import mounted_cameras

#: The largest simplification error allowed for the fixed cameras, in pixels at the mesh's
#: nearest vertex: under a pixel, so a distant mesh's outline moves by less than a pixel while
#: the mesh sheds most of its triangles. What it saves is the column "agentview draw, with
#: 0.5 mm distant meshes" of benchmarks/RESULTS.md, Fast rendering.
SCREEN_ERROR_PX = 0.25
#: The simplification errors (metres) a distant mesh may take: few, so the cache holds few copies.
LEVELS = (0.0005, 0.001, 0.002, 0.004, 0.008)


def still_geoms(model: Any, camera_ids: list[int]) -> np.ndarray:
    """Per geom: whether it cannot move and is not a fixture (see the module docstring)."""
    body = model.geom_bodyid
    robots = {int(model.body_rootid[model.cam_bodyid[c]]) for c in mounted_cameras(model, camera_ids)}
    owned = (body == 0) | np.isin(model.body_rootid[body], sorted(robots))
    return (model.body_weldid[body] == 0) & owned


def distant_errors(
    model: Any, camera_ids: list[int], size: int, drawn: np.ndarray, base: float
) -> dict[int, float]:
    """Mesh -> simplification error (metres) for the fixed cameras among ``camera_ids`` at
    ``size`` pixels, for the meshes coarser than ``base`` there. ``drawn``: per geom, whether
    a camera draws it. Meshes used by any geom that can move or is a fixture are left out."""
    import mujoco

    fixed = sorted(set(camera_ids) - mounted_cameras(model, camera_ids))
    if not fixed:
        return {}
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)  # the poses of what cannot move, and of the fixed cameras
    mujoco.mj_camlight(model, data)
    still = still_geoms(model, camera_ids)
    meshes = drawn & (model.geom_type == mujoco.mjtGeom.mjGEOM_MESH)
    moving = {int(model.geom_dataid[g]) for g in np.flatnonzero(meshes & ~still)}
    allowed: dict[int, float] = {}  # mesh -> metres that make SCREEN_ERROR_PX at its nearest vertex
    for g in np.flatnonzero(meshes & still):
        i = int(model.geom_dataid[g])
        if i in moving:
            continue
        start, count = int(model.mesh_vertadr[i]), int(model.mesh_vertnum[i])
        world = model.mesh_vert[start : start + count] @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
        for c in fixed:
            pixels_per_metre = (size / 2) / np.tan(np.deg2rad(model.cam_fovy[c]) / 2)  # at 1 m
            nearest = float(np.linalg.norm(world - data.cam_xpos[c], axis=1).min())
            allowed[i] = min(allowed.get(i, np.inf), SCREEN_ERROR_PX * nearest / pixels_per_metre)
    out = {}
    for i, metres in allowed.items():
        level = max((level for level in LEVELS if level <= metres), default=base)
        if level > base:
            out[i] = level
    return out
