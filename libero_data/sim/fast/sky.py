"""The skybox, left out of ``fast`` images where it is proved to show in no sample.

MuJoCo draws the skybox after the opaque geoms: a textured cylinder of radius 0.7 x the far
plane around the camera, depth-tested, so it colours only the samples no opaque geom covers.
LIBERO's scenes are rooms, and from their cameras every sample is covered (walls, floor, table):
the sky changes no pixel, yet under llvmpipe it is a full-screen textured, multisampled draw
that every frame pays for (benchmarks/RESULTS.md, Fast rendering: the column "draw with the
sky"). An occlusion query per frame costs about as much as the sky itself, so the proof is
made without one per frame:

- A fixed camera (on the world body, fixed mode): once per pose of the camera and of what does
  not move within an episode (the world body's geoms, fixtures), those are drawn alone without
  the sky, and one occlusion query asks whether any sample of a box between them and the sky
  would pass the depth test. None means they cover every sample; whatever else is drawn only
  covers more.
- Any other camera, every frame, from geometry: the four corner rays of its view all meet one
  face of an opaque still plane or box (a floor, a table top) from its front, within the face,
  beyond the near plane and well inside the sky. Every ray between them meets the face inside
  the same convex quadrilateral, so it covers every sample (the wrist camera looking down).

Where neither holds the sky is drawn, as MuJoCo draws it. The image is the same either way
(tested, and a scene whose sky shows is drawn with it).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from libero_data.sim.fast.culling import box_corners, fovy_views
from libero_data.sim.fast.hidden import box_samples, render_without, unmoving_geoms
from libero_data.sim.fast.meshes import DRAWN_GROUPS

#: The proof by plane asks every corner ray to meet the plane nearer than this share of the far
#: plane (the sky cylinder stands at 0.7 of it).
SKY_MARGIN = 0.5


class SkyCover:
    """Per camera and frame, whether the sky must be drawn (:meth:`shows`)."""

    def __init__(self, model: Any) -> None:
        import mujoco

        still = unmoving_geoms(model)
        self.still = np.flatnonzero(still)
        self.fovy = fovy_views(model)  # per camera: a view the corner rays below bound
        plane, box = int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_BOX)
        drawn = still & np.isin(model.geom_group, DRAWN_GROUPS)
        # The faces a camera may look at: a finite plane's front, each of a box's six.
        faces = [(g, 2, 1.0, 0.0) for g in np.flatnonzero(drawn & (model.geom_type == plane))]
        faces += [
            (g, a, s, 1.0)
            for g in np.flatnonzero(drawn & (model.geom_type == box))
            for a in range(3)
            for s in (1, -1)
        ]
        faces = [f for f in faces if np.all(model.geom_size[f[0], [a for a in range(3) if a != f[1]]] > 0)]
        self.face_geom = np.array([f[0] for f in faces], dtype=int)
        self.face_axis = np.array([f[1] for f in faces], dtype=int)
        self.face_sign = np.array([f[2] for f in faces], dtype=np.float64)
        self.face_lift = np.array([f[3] for f in faces], dtype=np.float64)  # 0: a plane, 1: a box
        self._proved: dict[int, tuple[bytes, bool]] = {}  # fixed camera -> (poses, covered)
        self._faces: tuple[bytes, tuple[np.ndarray, ...]] | None = None  # (poses, opaque faces)

    def shows(self, model: Any, data: Any, scene: Any, context: Any, viewport: Any, camera_id: int) -> bool:
        """Whether camera ``camera_id`` may see the sky in ``scene`` (an ``MjvScene`` updated for
        it, drawn with ``context`` into ``viewport``, the GL context current): False only where
        proved covered."""
        import mujoco

        fixed = (
            model.cam_bodyid[camera_id] == 0
            and model.cam_mode[camera_id] == mujoco.mjtCamLight.mjCAMLIGHT_FIXED
        )
        arrays = (data.geom_xpos[self.still], data.geom_xmat[self.still], model.geom_rgba, model.mat_rgba)
        still = b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)  # changes at a reset
        if fixed:
            key = data.cam_xpos[camera_id].tobytes() + data.cam_xmat[camera_id].tobytes() + still
            if camera_id not in self._proved or self._proved[camera_id][0] != key:
                covered = _still_covers(self.still, scene, context, viewport)
                self._proved[camera_id] = (key, covered)
            if self._proved[camera_id][1]:
                return False
        if not self.fovy[camera_id]:
            return True  # a view not set by its vertical angle alone: the rays below do not hold
        if self._faces is None or self._faces[0] != still:
            self._faces = (still, self._opaque_faces(model, data))
        return not _face_covers(model, data, camera_id, *self._faces[1])

    def _opaque_faces(self, model: Any, data: Any) -> tuple[np.ndarray, ...]:
        """Of the faces a camera may look at, those drawn opaque (MuJoCo's transparent pass: alpha
        below 0.995; the material's colour where the geom's is MuJoCo's default, as
        mjv_updateScene chooses): centres, outward normals, in-plane axes, half sizes."""
        g, axis = self.face_geom, self.face_axis
        rgba, material = model.geom_rgba[g], model.geom_matid[g]
        default = np.all(rgba == np.array([0.5, 0.5, 0.5, 1.0], dtype=rgba.dtype), axis=1) & (material >= 0)
        own = model.mat_rgba[np.maximum(material, 0), 3] if model.nmat else rgba[:, 3]
        keep = np.where(default, own, rgba[:, 3]) >= 0.995
        g, axis, rows = g[keep], axis[keep], np.arange(int(keep.sum()))
        frames = data.geom_xmat[g].reshape(-1, 3, 3)
        columns = np.arange(3)[None, :] != axis[:, None]  # the face's two in-plane axes
        tangents = frames.transpose(0, 2, 1)[columns].reshape(-1, 2, 3)
        normals = self.face_sign[keep][:, None] * frames[rows, :, axis]
        sizes = model.geom_size[g]
        centres = data.geom_xpos[g] + (self.face_lift[keep] * sizes[rows, axis])[:, None] * normals
        return centres, normals, tangents, sizes[columns].reshape(-1, 2)


def _face_covers(
    model: Any,
    data: Any,
    camera_id: int,
    centres: np.ndarray,
    normals: np.ndarray,
    tangents: np.ndarray,
    halves: np.ndarray,
) -> bool:
    """Whether one of the faces meets all four corner rays of the camera's view from its front,
    within its extent, beyond the near plane and well inside the sky."""
    if not len(centres):
        return False
    position = data.cam_xpos[camera_id]
    spread = np.tan(np.deg2rad(model.cam_fovy[camera_id] / 2))  # square images
    corners = np.array([[x, y, -1.0] for x in (-spread, spread) for y in (-spread, spread)])
    rays = corners @ data.cam_xmat[camera_id].reshape(3, 3).T  # world; view depth 1 per unit
    height = np.einsum("fk,fk->f", position - centres, normals)
    toward = rays @ normals.T  # (corner, face)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = height[None, :] / -toward  # view depth of each corner ray's meeting point
    hits = position + t[..., None] * rays[:, None, :] - centres[None]  # (corner, face, 3)
    local = np.abs(np.einsum("cfk,fjk->cfj", hits, tangents))
    extent = float(model.stat.extent)
    near, far = model.vis.map.znear * extent, model.vis.map.zfar * extent
    distance = t * np.linalg.norm(rays, axis=1)[:, None]
    meets = (height > 0) & np.all(toward < 0, axis=0) & np.all(t > near, axis=0)
    inside = np.all(local <= halves[None], axis=(0, 2)) & np.all(distance < SKY_MARGIN * far, axis=0)
    return bool(np.any(meets & inside))


def _still_covers(still: np.ndarray, scene: Any, context: Any, viewport: Any) -> bool:
    """Draw only the still geoms of ``scene``, without the sky, and ask whether any sample
    of a box around the camera, between them and the sky, passes the depth test."""
    import mujoco

    kept = set(int(g) for g in still)
    rows = [
        k
        for k in range(scene.ngeom)
        if not (scene.geoms[k].objtype == mujoco.mjtObj.mjOBJ_GEOM and int(scene.geoms[k].objid) in kept)
    ]
    sky = int(scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX])
    scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = 0
    try:
        render_without(scene, context, viewport, rows)
        camera = scene.camera[0]
        # Half-size 0.3 of the sky's radius: every corner (0.52 of it away) is nearer than the
        # sky's faceted cylinder along every ray, and far beyond any LIBERO scene.
        half = 0.3 * 0.7 * camera.frustum_far
        cube = np.array([[0.0, 0.0, 0.0, half, half, half]])
        box = box_corners(np.asarray(camera.pos, dtype=np.float64)[None], np.eye(3)[None], cube)
        passed = box_samples(box)[0]
    finally:
        scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = sky
    return passed == 0
