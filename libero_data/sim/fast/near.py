"""Free objects drawn finer while a mounted camera is near them (``render_quality="fast"``).

``fast`` simplifies every mesh to within 0.5 mm (:mod:`.meshes`), with the
normals weighed lightly. That holds a mesh's shape, but a finely bumped or curved object a few
centimetres from the wrist camera also shows its normals: there a drifted normal moves the
shading inside the object. Pushing the gripper down onto a bowl, nearly all of the wrist
image's |fast - full| lies inside the bowl, and it grows with the bowl's share of the frame
until it passes :data:`~libero_data.sim.fast.images.FAST_MEAN_BOUND` (benchmarks/RESULTS.md, Fast
rendering). The free objects (what the tasks move, and what the gripper approaches) therefore
get a second, detailed copy, simplified with :attr:`MeshSettings.object_normal_weight`; the
mounted cameras' context holds it only while one of them is within :data:`NEAR_OBJECT_M` of
the object, so the triangles it costs are drawn only there, not in every frame of every camera.
Deciding takes one distance per camera and geom; a mesh is taken out and uploaded again only
when a camera crosses the distance, which happens as the camera comes and goes, not every
frame.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from libero_data.sim.fast.cameras import camera_meshes, mounted_cameras
from libero_data.sim.fast.meshes import (
    CacheReport,
    MeshCache,
    MeshData,
    MeshSettings,
    apply_faces,
    drawn_meshes,
)

#: A free object is drawn from its detailed copy (:func:`detailed_objects`) by a mounted camera
#: within this many metres of the object's bounding sphere. The nearer the camera, the more of
#: the frame the object fills and the more the coarse copy's shading moves the wrist image
#: away from ``full``; swapping at this distance keeps the worst wrist frame along the
#: benchmark's push within :data:`~libero_data.sim.fast.images.FAST_MEAN_BOUND` in every sampled
#: scene (tests/sim/test_fast_render_scenes.py; benchmarks/RESULTS.md, Fast rendering).
NEAR_OBJECT_M = 0.15


def object_meshes(model: Any) -> set[int]:
    """Meshes of the geoms of free objects: bodies under a free joint (what a task moves)."""
    import mujoco

    root = model.body_rootid[model.geom_bodyid]
    first = model.body_jntadr[root]
    free = (first >= 0) & (model.jnt_type[np.maximum(first, 0)] == mujoco.mjtJoint.mjJNT_FREE)
    is_mesh = model.geom_type == mujoco.mjtGeom.mjGEOM_MESH
    return {int(i) for i in model.geom_dataid[is_mesh & free]}


def detailed_objects(
    model: Any,
    camera_ids: list[int],
    settings: MeshSettings | None = None,
    cache_dir: str | Path | None = None,
    *,
    progress: bool | None = None,
) -> tuple[dict[int, np.ndarray], CacheReport]:
    """The drawn meshes of free objects simplified with ``settings.object_normal_weight`` as
    their normals' weight (cached like the others): what a mounted camera draws near them."""
    settings = settings or MeshSettings()
    meshes = (set(drawn_meshes(model)) & object_meshes(model)) - camera_meshes(model, camera_ids)
    found, report = MeshCache(cache_dir).simplified(
        {i: MeshData.from_model(model, i) for i in sorted(meshes)},
        settings.replace(normal_weight=settings.object_normal_weight),
        progress=progress,
    )
    return found, report


class NearDetail:
    """Which copy of each free object's mesh a context holds: the detailed one (``detail``) while
    one of the mounted cameras among ``camera_ids`` is within ``near`` metres of the bounding
    sphere of a geom that uses the mesh, the coarse one (``faces``) otherwise. The choice follows
    the simulated state alone (whichever camera is drawn), so an image never depends on what was
    drawn before it. ``render_model`` is ``model``'s copy the context was built from (holding
    ``faces``); its meshes are rewritten in place and uploaded again only when a camera crosses
    the distance."""

    def __init__(
        self,
        model: Any,
        render_model: Any,
        camera_ids: list[int],
        faces: dict[int, np.ndarray],
        detail: dict[int, np.ndarray],
        near: float = NEAR_OBJECT_M,
    ) -> None:
        import mujoco

        self.model, self.fine, self.near = render_model, detail, near
        self.coarse = {i: faces[i] for i in detail}
        self.capacity = {i: int(model.mesh_facenum[i]) for i in detail}  # as compiled
        self.cameras = sorted(mounted_cameras(model, camera_ids))
        uses = (model.geom_type == mujoco.mjtGeom.mjGEOM_MESH) & np.isin(model.geom_dataid, sorted(detail))
        self.geoms = np.flatnonzero(uses)  # every geom drawing one of the meshes, and its mesh
        self.mesh_of = model.geom_dataid[self.geoms]
        self.detailed: set[int] = set()  # meshes whose detailed copy the context holds now

    def wanted(self, model: Any, data: Any) -> set[int]:
        """The meshes a mounted camera is near now (live ``model``/``data``)."""
        offsets = data.geom_xpos[self.geoms][None] - data.cam_xpos[self.cameras][:, None]
        gaps = np.linalg.norm(offsets, axis=-1) - model.geom_rbound[self.geoms]  # (cameras, geoms)
        return {int(i) for i in self.mesh_of[(gaps < self.near).any(axis=0)]}

    def update(self, model: Any, data: Any, context: Any, facenum: np.ndarray) -> None:
        """Put the copies the state needs in the render copy, upload those that changed into
        ``context`` (an ``MjrContext`` built from it, current) and count them in ``facenum``."""
        import mujoco

        wanted = self.wanted(model, data)
        for i in sorted(wanted ^ self.detailed):
            apply_faces(self.model, i, (self.fine if i in wanted else self.coarse)[i], self.capacity[i])
            mujoco.mjr_uploadMesh(self.model, context, i)
            facenum[i] = self.model.mesh_facenum[i]
        self.detailed = wanted
