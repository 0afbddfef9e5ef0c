"""Free objects drawn finer while a mounted camera is near them (``render_quality="fast"``).

``fast`` simplifies every mesh to within 0.5 mm (:mod:`libero_data.sim.meshes`), with the
normals weighed lightly. That holds a mesh's shape, but a finely bumped or curved object a few
centimetres from the wrist camera also shows its normals: there a drifted normal moves the
shading inside the object. Pushing the gripper down onto libero_90/23's black bowl, 96% of the
wrist image's |fast - full| (0.0123, above :data:`~libero_data.sim.render.FAST_MEAN_BOUND`)
lay inside the bowl, and it grew with the bowl's share of the frame. The free objects (what the
tasks move, and what the gripper approaches) therefore get a second, detailed copy, simplified
with :attr:`MeshSettings.object_normal_weight`; the mounted cameras' context holds it only while
one of them is within :data:`NEAR_OBJECT_M` of the object, so the triangles it costs are drawn
only there (every free object detailed all the time: libero_object/8 drew 79% more triangles).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from libero_data.sim.meshes import (
    CacheReport,
    MeshCache,
    MeshData,
    MeshSettings,
    apply_faces,
    camera_meshes,
    drawn_meshes,
)

#: A free object is drawn from its detailed copy (:func:`detailed_objects`) by a mounted camera
#: within this many metres of the object's bounding sphere. Pushing the gripper down onto
#: libero_90/23's bowl, the wrist image's |fast - full| with the coarse copies grows with the
#: bowl's share of the frame: 0.0071 at 0.144 m, 0.0123 at 0.083 m; nearer than 0.15 m the
#: detailed copies keep it at or below 0.0060 (a one-off script, 2026-11-27).
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
    """Which copy of each free object's mesh a context holds: the detailed one while one of the
    mounted ``cameras`` is within ``near`` metres of the bounding sphere of a geom that uses
    the mesh, the coarse one otherwise. The choice follows the simulated state alone (whichever
    camera is drawn), so an image never depends on what was drawn before it. ``model`` is the
    render copy the context was built from; its meshes are rewritten in place and :meth:`swap`
    names those the context must upload again (only when a camera crosses the distance)."""

    def __init__(
        self,
        model: Any,
        coarse: dict[int, np.ndarray],
        fine: dict[int, np.ndarray],
        capacity: dict[int, int],
        cameras: frozenset[int],
        near: float = NEAR_OBJECT_M,
    ) -> None:
        import mujoco

        self.model, self.coarse, self.fine, self.capacity = model, coarse, fine, capacity
        self.cameras, self.near = sorted(cameras), near
        is_mesh = model.geom_type == mujoco.mjtGeom.mjGEOM_MESH
        self.geoms = {i: np.flatnonzero(is_mesh & (model.geom_dataid == i)) for i in fine}
        self.detailed: set[int] = set()  # meshes whose detailed copy the context holds now

    def wanted(self, model: Any, data: Any) -> set[int]:
        """The meshes a mounted camera is near now (live ``model``/``data``)."""
        out = set()
        for i, geoms in self.geoms.items():
            if not geoms.size:
                continue
            for camera in self.cameras:
                gap = np.linalg.norm(data.geom_xpos[geoms] - data.cam_xpos[camera], axis=1)
                if float((gap - model.geom_rbound[geoms]).min()) < self.near:
                    out.add(i)
                    break
        return out

    @classmethod
    def of(
        cls,
        model: Any,
        render_model: Any,
        camera_ids: list[int],
        faces: dict[int, np.ndarray],
        detail: dict[int, np.ndarray],
    ) -> NearDetail:
        """For a context built from ``render_model`` (``model``'s copy holding ``faces``):
        ``detail``'s copies near the mounted cameras among ``camera_ids``."""
        from libero_data.sim.distant import mounted_cameras

        capacity = {i: int(model.mesh_facenum[i]) for i in detail}
        cameras = mounted_cameras(model, camera_ids)
        return cls(render_model, {i: faces[i] for i in detail}, detail, capacity, cameras)

    def update(self, model: Any, data: Any, context: Any, facenum: np.ndarray) -> None:
        """Swap the copies the state needs into ``context`` (an ``MjrContext`` built from
        :attr:`model`, current) and ``facenum`` (its triangles per mesh)."""
        import mujoco

        for i in self.swap(model, data):
            mujoco.mjr_uploadMesh(self.model, context, i)
            facenum[i] = self.model.mesh_facenum[i]

    def swap(self, model: Any, data: Any) -> list[int]:
        """Put in the render copy the copies the state needs; the meshes that changed."""
        wanted = self.wanted(model, data)
        changed = sorted(wanted ^ self.detailed)
        for i in changed:
            apply_faces(self.model, i, (self.fine if i in wanted else self.coarse)[i], self.capacity[i])
        self.detailed = wanted
        return changed
