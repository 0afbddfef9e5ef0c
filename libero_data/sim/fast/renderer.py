"""Our own offscreen renderer: MuJoCo's, set up the way robosuite sets up its own.

:class:`OffscreenRenderer` has the same visualisation options as robosuite's offscreen renderer
(collision geometry hidden, a 1000-geom scene, the model's multisampling): given the model
robosuite draws, it gives robosuite's pixels exactly (tested). Its GL context owns the meshes it
was built from, while the scene is updated from the live model and data; so a context built from
a copy whose meshes were simplified draws the simulated scene with fewer triangles and nothing
else changed (cameras, lights, colours and poses all come from the simulator as it is at that
moment). What ``fast`` adds is passed in: culling (:mod:`.culling`), the cameras drawn without
the mirror pass (:mod:`.cameras`), free objects' detailed copies (:mod:`.near`), large still
meshes left out when hidden (:mod:`.hidden`) and the sky where it may show (:mod:`.sky`).

A frame is three steps, public so that a benchmark can time each: :meth:`update` (the scene
as the camera sees the state), :meth:`draw` (``mjr_render``) and :meth:`read` (the pixels back
into memory); :meth:`render` runs them and returns the upright image.
"""

from __future__ import annotations

import atexit
import weakref
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.sim.fast.culling import cull_outside_view, fovy_views
from libero_data.sim.fast.meshes import DRAWN_GROUPS
from libero_data.sim.gl import gl_strings

if TYPE_CHECKING:
    from libero_data.sim.fast.hidden import HiddenGeoms
    from libero_data.sim.fast.near import NearDetail
    from libero_data.sim.fast.sky import SkyCover


class OffscreenRenderer:
    """Square images of a model's fixed cameras, in a GL context of its own."""

    def __init__(
        self,
        model: Any,
        size: int,
        backend: str | None = None,
        *,
        cull: bool = False,
        unmirrored: frozenset[int] = frozenset(),
        detail: NearDetail | None = None,
        hidden: HiddenGeoms | None = None,
        sky: SkyCover | None = None,
    ) -> None:
        import mujoco

        self.size, self.detail = size, detail  # detail: free objects' copies swapped in when near
        self.hidden, self.sky = hidden, sky  # large still meshes hidden from the wrist; the sky
        # Cameras drawn without MuJoCo's mirror pass (every geom again, in the first mirror).
        self.unmirrored = unmirrored
        # Out-of-view geoms cost vertex work, no pixels: left out, unless shadows or views culling can't bound.
        self.cull = cull and bool(np.all(fovy_views(model))) and not np.any(model.light_castshadow)
        self._ctx = _gl_context(backend, size)
        self._ctx.make_current()
        # The offscreen buffer takes the model's offwidth/offheight; an image-sized buffer
        # is cleared and resolved faster and gives the same pixels in the viewport.
        vis = model.vis.global_
        saved = (vis.offwidth, vis.offheight)
        vis.offwidth, vis.offheight = size, size
        try:
            self._con = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
        finally:
            vis.offwidth, vis.offheight = saved
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._con)
        _LIVE.add(self)
        if not _EXIT_HOOK:
            # Registered after the first context (and so after EGL's own exit hook, which
            # terminates the display): at exit, live renderers are freed while EGL still works,
            # instead of by the garbage collector afterwards (which prints an EGL traceback).
            atexit.register(_close_all)
            _EXIT_HOOK.append(True)
        self._scene = mujoco.MjvScene(model, maxgeom=1000)
        self._option = mujoco.MjvOption()
        for group in range(len(self._option.geomgroup)):
            self._option.geomgroup[group] = int(group in DRAWN_GROUPS)
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._perturb = mujoco.MjvPerturb()
        self._viewport = mujoco.MjrRect(0, 0, size, size)
        self._pixels = np.empty((size, size, 3), dtype=np.uint8)
        self._facenum = np.array(model.mesh_facenum, copy=True)  # the meshes this context draws

    @property
    def scene(self) -> Any:
        """The ``MjvScene`` as the last :meth:`update` left it (its flags say what was drawn)."""
        return self._scene

    @property
    def context(self) -> Any:
        """The ``MjrContext``: the meshes and textures this renderer's GL context holds."""
        return self._con

    @property
    def viewport(self) -> Any:
        """The ``MjrRect`` drawn into: the whole square image."""
        return self._viewport

    @property
    def facenum(self) -> np.ndarray:
        """Triangles per mesh as this context holds them now (a read-only view)."""
        view = self._facenum.view()
        view.flags.writeable = False
        return view

    def render(self, model: Any, data: Any, camera_id: int) -> np.ndarray:
        """The upright image of camera ``camera_id`` for the scene in ``data``."""
        self.make_current()
        self.update(model, data, camera_id)
        self.draw(model, camera_id)
        self.read()
        return self.image()

    def make_current(self) -> None:
        """Make this renderer's GL context the current one (every step below needs it)."""
        self._ctx.make_current()

    def update(self, model: Any, data: Any, camera_id: int) -> None:
        """The scene as camera ``camera_id`` sees ``data`` (geoms out of its view left out), and
        whether the mirror pass and the sky are drawn in it."""
        import mujoco

        self._camera.fixedcamid = camera_id
        self._scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = camera_id not in self.unmirrored
        if self.detail is not None:
            self.detail.update(model, data, self._con, self._facenum)
        mujoco.mjv_updateScene(
            model, data, self._option, self._perturb, self._camera, mujoco.mjtCatBit.mjCAT_ALL, self._scene
        )
        if self.cull:
            cull_outside_view(self._scene, model, data, camera_id)
        if self.sky is not None:  # drawn where it may show
            shows = self.sky.shows(model, data, self._scene, self._con, self._viewport, camera_id)
            self._scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = shows

    def draw(self, model: Any, camera_id: int) -> list[int]:
        """``mjr_render`` the scene :meth:`update` made; returns the scene rows
        :class:`.hidden.HiddenGeoms` left out (proved hidden)."""
        import mujoco

        if self.hidden is not None and camera_id in self.unmirrored:
            return self.hidden.draw(model, self._scene, self._con, self._viewport, camera_id)
        mujoco.mjr_render(self._viewport, self._scene, self._con)
        return []

    def read(self) -> None:
        """Read the drawn pixels back into memory (:meth:`image` returns them upright)."""
        import mujoco

        mujoco.mjr_readPixels(self._pixels, None, self._viewport, self._con)

    def image(self) -> np.ndarray:
        """A copy of the pixels last read, upright."""
        # Read bottom-up, from cameras mounted rolled by 180 degrees (see LiberoEnv.render).
        return np.ascontiguousarray(self._pixels[::-1, ::-1])

    def triangles(self, left_out: Iterable[int] = ()) -> int:
        """The mesh triangles in the scene drawn, without the scene rows ``left_out``."""
        import mujoco

        # A scene's mesh geom names its mesh as 2 * id (2 * id + 1: its convex hull, not drawn here).
        mesh = int(mujoco.mjtGeom.mjGEOM_MESH)
        skip = set(left_out)
        geoms = (self._scene.geoms[k] for k in range(self._scene.ngeom) if k not in skip)
        return sum(int(self._facenum[g.dataid // 2]) for g in geoms if g.type == mesh)

    def gl_info(self, backend: str | None) -> dict[str, str]:
        self._ctx.make_current()
        return gl_strings(backend)

    def close(self) -> None:
        con, ctx = self.__dict__.pop("_con", None), self.__dict__.pop("_ctx", None)
        _LIVE.discard(self)
        if ctx is not None:
            ctx.make_current()
            if con is not None:
                con.free()
            ctx.free()


_LIVE: weakref.WeakSet[OffscreenRenderer] = weakref.WeakSet()
_EXIT_HOOK: list[bool] = []


def _close_all() -> None:
    for renderer in list(_LIVE):
        renderer.close()


def _gl_context(backend: str | None, size: int) -> Any:
    """A headless GL context of ``backend`` (``mujoco.GLContext`` is whatever MUJOCO_GL said at import)."""
    import mujoco

    if backend == "egl":
        from mujoco.egl import GLContext as EGLContext

        return EGLContext(size, size)
    if backend == "osmesa":
        from mujoco.osmesa import GLContext as OSMesaContext

        return OSMesaContext(size, size)
    return mujoco.GLContext(size, size)
