"""What lies in a camera's view: the views it can bound, geoms' bounding boxes, and culling.

``fast`` leaves out of a camera's scene the geoms that lie wholly outside its view: they cost
vertex work and give no pixel (:func:`cull_outside_view`). The bounds hold all of each geom,
so the image is the same (tested). :func:`box_corners` is also what the occlusion queries of
:mod:`.hidden` and the sky's proof (:mod:`.sky`) draw.
"""

from __future__ import annotations

from typing import Any

import numpy as np

_SIGNS = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=np.float64)


def fovy_views(model: Any) -> np.ndarray:
    """Per camera: whether its view is a perspective set by its vertical angle ``cam_fovy`` alone
    (not orthographic, where ``cam_fovy`` is a width in metres, and no sensor size), the view that
    culling and the sky's corner rays bound."""
    return (model.cam_projection == 0) & ~np.any(model.cam_sensorsize > 0, axis=-1)


def box_corners(pos: np.ndarray, mat: np.ndarray, aabb: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """The world corners ``(n, 8, 3)`` of geoms' bounding boxes, each enlarged by ``margin``:
    ``pos`` ``(n, 3)`` and ``mat`` ``(n, 3, 3)`` the geoms' frames, ``aabb`` ``(n, 6)`` MuJoCo's
    ``geom_aabb`` (centre, then half-sizes, in the geom's frame). Corner ``i`` takes the sign
    ``-``/``+`` per axis from the bits of ``i`` (x the highest)."""
    local = aabb[:, None, :3] + _SIGNS[None] * (aabb[:, None, 3:] + margin)
    return pos[:, None] + local @ mat.transpose(0, 2, 1)


def cull_outside_view(scene: Any, model: Any, data: Any, camera_id: int) -> int:
    """Mark the scene's model geoms that lie wholly outside the camera's view as not drawn.

    A geom is outside when its bounding sphere, or all eight corners of its bounding box (MuJoCo's
    ``geom_aabb``, in the geom's frame), lie beyond one of the view's four side planes or behind
    the camera. Both bounds hold all of the geom, so a geom that could touch a pixel is always
    kept: the image is the same (tested). The box is the tighter of the two for long or flat
    geoms (a bookshelf, a wall, the robot's pedestal), whose spheres reach far into the view
    from beside or behind the robot while their boxes do not (benchmarks/RESULTS.md, Fast
    rendering: culling by bounding box as well as sphere). Returns how many geoms were left out.
    """
    import mujoco

    position = data.cam_xpos[camera_id]
    rotation = data.cam_xmat[camera_id].reshape(3, 3)
    half = np.deg2rad(model.cam_fovy[camera_id] / 2)  # square images: the same angle both ways
    sin, cos = np.sin(half), np.cos(half)
    geoms = [scene.geoms[k] for k in range(scene.ngeom)]
    rows = [k for k, g in enumerate(geoms) if g.objtype == mujoco.mjtObj.mjOBJ_GEOM]
    if not rows:
        return 0
    objids = [geoms[k].objid for k in rows]
    radius = model.geom_rbound[objids]
    centres = np.array([geoms[k].pos for k in rows], dtype=np.float64)
    turns = np.array([geoms[k].mat for k in rows], dtype=np.float64).reshape(-1, 3, 3)
    corners = box_corners(centres, turns, model.geom_aabb[objids])
    points = np.concatenate([centres[:, None], corners], axis=1)
    local = (points - position) @ rotation  # (geoms, centre + 8 corners, 3) in the camera's frame
    reach = np.concatenate([radius[:, None], np.zeros((len(rows), 8))], axis=1)
    depth = -local[..., 2]  # cameras look along their -z axis
    beyond = [depth + reach < 0] + [
        sign * local[..., axis] * cos - depth * sin > reach for axis in (0, 1) for sign in (1, -1)
    ]
    outside = np.zeros(len(rows), dtype=bool)
    for plane in beyond:  # the sphere beyond it, or all eight corners
        outside |= plane[:, 0] | plane[:, 1:].all(axis=1)
    outside &= radius > 0  # planes and the like have no bounding sphere
    none = int(mujoco.mjtGeom.mjGEOM_NONE)
    for k in np.flatnonzero(outside):
        geoms[rows[k]].type = none
    return int(outside.sum())
