"""Large still meshes a mounted camera cannot see, left out once the GL proves them hidden.

The robot's pedestal, a large mesh even at ``fast``'s 0.5 mm, stands in every LIBERO scene
under the robot's base, beside the table. From the wrist camera, above the table, the base and
the table top hide it: a segmentation image of the wrist frame shows no pixel of it, yet
drawing it is a large share of that frame's work. No plane or box test proves it hidden (it
rises above the table top, behind the base), but the depth buffer does. What the queries save
is the column "wrist draw, without occlusion queries" of benchmarks/RESULTS.md, Fast rendering.

:class:`HiddenGeoms` draws a mounted camera's scene without the large still meshes it believes
hidden, then asks the GL (an occlusion query) whether any sample of each one's bounding box,
slightly enlarged, would pass the depth test against what was drawn. The box holds its mesh, so
a box none of whose samples pass proves the mesh changes no pixel: the image is the one drawn
with it (tested). If a box shows, the scene is drawn again with the mesh, and the mesh is
believed visible: left in, and tested again after :data:`RETEST_FRAMES` frames (then twice as
many, up to :data:`RETEST_MAX`), so a mesh in view costs a second draw rarely. Whatever is
believed, the image is the full scene's: only the time depends on what was drawn before.

Only for cameras drawn without the mirror pass (a reflection may show the mesh). MuJoCo draws
transparent geoms without writing depth (libero_10/9's wrist frame with its 0.25-alpha geom has
the same depth buffer with and without it), so a mesh behind glass shows to the query too.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from libero_data.sim.fast.culling import box_corners
from libero_data.sim.fast.meshes import drawn_geoms

#: Meshes with fewer triangles (in the drawing context) are not worth a query.
MIN_TRIANGLES = 4000
#: The bounding box is enlarged by this much (metres) on every side before the query.
BOX_MARGIN_M = 0.002
#: A mesh found visible is tested again after this many of the camera's frames, then after
#: twice as many each time it is found visible again, up to :data:`RETEST_MAX`.
RETEST_FRAMES = 8
RETEST_MAX = 64

_FACES = ((0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5))


def large_still_meshes(model: Any) -> set[int]:
    """Geoms of ``model`` (the copy a context draws) drawing a mesh of at least
    :data:`MIN_TRIANGLES` on a body that never moves (welded to the world, not under a mocap body)."""
    import mujoco

    still = unmoving_geoms(model)
    meshes = drawn_geoms(model) & (model.geom_type == mujoco.mjtGeom.mjGEOM_MESH)
    large = model.mesh_facenum[np.maximum(model.geom_dataid, 0)] >= MIN_TRIANGLES
    return {int(g) for g in np.flatnonzero(still & meshes & large)}


def unmoving_geoms(model: Any) -> np.ndarray:
    """Per geom: whether it does not move within an episode (on a body welded to the world, not
    under a mocap body: the world body's geoms, and fixtures, which LIBERO places at each reset)."""
    body = model.geom_bodyid
    return (model.body_weldid[body] == 0) & (model.body_mocapid[model.body_rootid[body]] < 0)


class HiddenGeoms:
    """Per camera, which of ``geoms`` (see :func:`large_still_meshes`) are believed hidden, and
    the draw that leaves them out when the GL proves it."""

    def __init__(self, geoms: set[int]) -> None:
        self.geoms = geoms
        # (camera, geom) found visible -> (frames until its next test, the interval it waited)
        self._visible: dict[tuple[int, int], tuple[int, int]] = {}

    @property
    def found_visible(self) -> set[tuple[int, int]]:
        """The (camera, geom) pairs last found visible, drawn until their next test."""
        return set(self._visible)

    def draw(self, model: Any, scene: Any, context: Any, viewport: Any, camera_id: int) -> list[int]:
        """``mjr_render`` the scene (its GL context current): without the meshes proved hidden.
        Returns the scene rows left out."""
        import mujoco

        rows = self._due(scene, camera_id)
        if not rows:
            mujoco.mjr_render(viewport, scene, context)
            return []
        render_without(scene, context, viewport, rows)
        shown = _showing(model, scene, rows)
        for k in rows:
            key = (camera_id, int(scene.geoms[k].objid))
            if k in shown:
                interval = (
                    min(2 * self._visible[key][1], RETEST_MAX) if key in self._visible else RETEST_FRAMES
                )
                self._visible[key] = (interval, interval)
            else:
                self._visible.pop(key, None)
        hidden = [k for k in rows if k not in shown]
        if shown:  # drawn again with what showed, still without what was proved hidden
            render_without(scene, context, viewport, hidden)
        return hidden

    def _due(self, scene: Any, camera_id: int) -> list[int]:
        """The scene rows to leave out and test now: candidates in the scene believed hidden or
        due for a test."""
        import mujoco

        mesh = int(mujoco.mjtGeom.mjGEOM_MESH)
        rows = []
        for k in range(scene.ngeom):
            g = scene.geoms[k]
            if g.type != mesh or g.objtype != mujoco.mjtObj.mjOBJ_GEOM or int(g.objid) not in self.geoms:
                continue
            key = (camera_id, int(g.objid))
            wait, interval = self._visible.get(key, (0, 0))
            if wait > 1:
                self._visible[key] = (wait - 1, interval)
            else:
                rows.append(k)
        return rows


def render_without(scene: Any, context: Any, viewport: Any, rows: list[int]) -> None:
    """``mjr_render`` the scene without its geoms ``rows`` (left in the scene as they were)."""
    import mujoco

    kinds = [int(scene.geoms[k].type) for k in rows]
    for k in rows:
        scene.geoms[k].type = int(mujoco.mjtGeom.mjGEOM_NONE)
    try:
        mujoco.mjr_render(viewport, scene, context)
    finally:
        for k, kind in zip(rows, kinds, strict=True):
            scene.geoms[k].type = kind


def _showing(model: Any, scene: Any, rows: list[int]) -> set[int]:
    """The scene rows among ``rows`` whose enlarged bounding box has a sample passing the depth
    test against the frame just drawn (:func:`box_samples`)."""
    geoms = [scene.geoms[k] for k in rows]
    corners = box_corners(
        np.array([g.pos for g in geoms], dtype=np.float64),
        np.array([g.mat for g in geoms], dtype=np.float64).reshape(-1, 3, 3),
        model.geom_aabb[[g.objid for g in geoms]],
        BOX_MARGIN_M,
    )
    camera = scene.camera[0]
    depth = (corners - np.asarray(camera.pos)) @ np.asarray(camera.forward)
    cut = depth.min(axis=1) <= 1.01 * camera.frustum_near  # the near plane would cut the box open
    shown = {k for k, c in zip(rows, cut, strict=True) if c}
    asked = [i for i, c in enumerate(cut) if not c]
    if not asked:
        return shown
    for i, passed in zip(asked, box_samples(corners[asked]), strict=True):
        if passed > 0:
            shown.add(rows[i])
    return shown


def box_samples(boxes: np.ndarray) -> list[int]:
    """How many samples of each box (``boxes``: (n, 8, 3) corners, as :func:`.culling.box_corners`
    orders them) pass the depth test against the frame just drawn (matrices and depth test as
    ``mjr_render`` left them), colour and depth writes off: one occlusion query each, all issued
    before any result is read."""
    from OpenGL import GL

    queries = np.ravel(GL.glGenQueries(len(boxes))).astype(np.uint32)
    GL.glPushAttrib(GL.GL_ALL_ATTRIB_BITS)
    try:
        GL.glColorMask(GL.GL_FALSE, GL.GL_FALSE, GL.GL_FALSE, GL.GL_FALSE)
        GL.glDepthMask(GL.GL_FALSE)
        for capability in (
            GL.GL_CULL_FACE,
            GL.GL_TEXTURE_2D,
            GL.GL_LIGHTING,
            GL.GL_ALPHA_TEST,
            GL.GL_STENCIL_TEST,
        ):
            GL.glDisable(capability)
        for query, corners in zip(queries, boxes, strict=True):
            GL.glBeginQuery(GL.GL_SAMPLES_PASSED, int(query))
            GL.glBegin(GL.GL_QUADS)
            for face in _FACES:
                for corner in face:
                    GL.glVertex3d(*corners[corner])
            GL.glEnd()
            GL.glEndQuery(GL.GL_SAMPLES_PASSED)
    finally:
        GL.glPopAttrib()
    passed = [int(GL.glGetQueryObjectuiv(int(query), GL.GL_QUERY_RESULT)) for query in queries]
    GL.glDeleteQueries(len(queries), queries)
    return passed
