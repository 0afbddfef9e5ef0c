"""``render_quality="fast"``: the scene drawn from simplified visual meshes, in our own GL context.

:class:`OffscreenRenderer` is MuJoCo's renderer set up the way robosuite sets up its offscreen
renderer (the same visualisation options, collision geometry hidden, a 1000-geom scene, the
model's multisampling): given the model robosuite draws, it gives robosuite's pixels exactly
(tested). Its GL context owns the meshes it was built from, while the scene is updated from
the live model and data; so a context built from a copy whose meshes were simplified draws
the simulated scene with fewer triangles and nothing else changed (cameras, lights, colours
and poses all come from the simulator as it is at that moment).

:func:`fast_renderer` builds that copy: the meshes that cameras see are simplified
(:mod:`libero_data.sim.meshes`, cached), except those on a camera's own body and below it (the
gripper fills much of the wrist camera's image); the wrist camera is drawn without MuJoCo's
mirror pass (:func:`.distant.mounted_cameras`), and the sky only where it may show (:mod:`.sky`).
"""

from __future__ import annotations

import atexit
import copy
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.sim.meshes import (
    ALGORITHM,
    DRAWN_GROUPS,
    CacheReport,
    MeshCache,
    MeshData,
    MeshSettings,
    apply_faces,
    box_corners,
    camera_meshes,
    drawn_geoms,
    drawn_meshes,
    fovy_views,
)

if TYPE_CHECKING:
    from libero_data.sim.hidden import HiddenGeoms
    from libero_data.sim.near import NearDetail
    from libero_data.sim.sky import SkyCover

#: The largest mean |fast - full| per camera image (0-1 scale) that ``fast`` is held to. Measured
#: on one scene of each suite at 128 and 256 px: 0.0015-0.0085, always below the error the
#: datasets' AV1 encoding adds to the same full-quality frames (0.0076-0.0120); see "Fast
#: rendering" in benchmarks/RESULTS.md.
FAST_MEAN_BOUND = 0.01


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
        # Out-of-view geoms cost vertex work, no pixels: left out, unless shadows or views _cull can't bound.
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

    def render(self, model: Any, data: Any, camera_id: int) -> np.ndarray:
        """The upright image of camera ``camera_id`` for the scene in ``data``."""
        import mujoco

        self._ctx.make_current()
        self._update(model, data, camera_id)
        self._draw(model, camera_id)
        mujoco.mjr_readPixels(self._pixels, None, self._viewport, self._con)
        # Read bottom-up, from cameras mounted rolled by 180 degrees (see LiberoEnv.render).
        return np.ascontiguousarray(self._pixels[::-1, ::-1])

    def _draw(self, model: Any, camera_id: int) -> list[int]:
        """``mjr_render`` the scene; returns the scene rows :class:`.hidden.HiddenGeoms` left out."""
        import mujoco

        if self.hidden is not None and camera_id in self.unmirrored:
            return self.hidden.draw(model, self._scene, self._con, self._viewport, camera_id)
        mujoco.mjr_render(self._viewport, self._scene, self._con)
        return []

    def _update(self, model: Any, data: Any, camera_id: int) -> None:
        """The scene as camera ``camera_id`` sees ``data`` (geoms out of its view left out)."""
        import mujoco

        self._camera.fixedcamid = camera_id
        self._scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = camera_id not in self.unmirrored
        if self.detail is not None:
            self.detail.update(model, data, self._con, self._facenum)
        mujoco.mjv_updateScene(
            model, data, self._option, self._perturb, self._camera, mujoco.mjtCatBit.mjCAT_ALL, self._scene
        )
        if self.cull:
            _cull(self._scene, model, data, camera_id)
        if self.sky is not None:  # drawn where it may show
            self._scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = self.sky.shows(model, data, self, camera_id)

    def render_timed(self, model: Any, data: Any, camera_id: int) -> dict[str, float]:
        """What :meth:`render` spends, in its three parts, each run to completion (seconds):
        ``update`` (the scene's poses, and culling), ``draw`` (``mjr_render`` and the GL work it
        queued, finished) and ``read`` (the pixels back into memory), and ``triangles``: the
        mesh triangles in the scene drawn. For measurements; the image is :meth:`render`'s."""
        import time

        import mujoco
        from OpenGL import GL

        self._ctx.make_current()
        GL.glFinish()
        start = time.perf_counter()
        self._update(model, data, camera_id)
        updated = time.perf_counter()
        left_out = set(self._draw(model, camera_id))
        GL.glFinish()
        drawn = time.perf_counter()
        mujoco.mjr_readPixels(self._pixels, None, self._viewport, self._con)
        read = time.perf_counter()
        # A scene's mesh geom names its mesh as 2 * id (2 * id + 1: its convex hull, not drawn here).
        mesh = int(mujoco.mjtGeom.mjGEOM_MESH)
        geoms = (self._scene.geoms[k] for k in range(self._scene.ngeom) if k not in left_out)
        triangles = sum(int(self._facenum[g.dataid // 2]) for g in geoms if g.type == mesh)
        return {
            "update": updated - start,
            "draw": drawn - updated,
            "read": read - drawn,
            "triangles": triangles,
        }

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


def _cull(scene: Any, model: Any, data: Any, camera_id: int) -> int:
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


def gl_strings(backend: str | None) -> dict[str, str]:
    """The current OpenGL context's vendor, renderer and version (and the backend named)."""
    from OpenGL import GL

    return {
        "backend": str(backend),
        "vendor": GL.glGetString(GL.GL_VENDOR).decode(errors="replace"),
        "renderer": GL.glGetString(GL.GL_RENDERER).decode(errors="replace"),
        "version": GL.glGetString(GL.GL_VERSION).decode(errors="replace"),
    }


@dataclass(frozen=True)
class FastScene:
    """What :func:`fast_renderer` draws: triangles per frame of all drawn geoms (a camera draws
    those in its view) at full and at fast quality, and the cache's work."""

    faces_drawn_before: int
    faces_drawn_after: int
    meshes_simplified: int
    meshes_kept_whole: int
    cache: CacheReport


def fast_renderer(
    model: Any,
    size: int,
    camera_ids: list[int],
    faces: dict[int, np.ndarray],
    texture_cap: int,
    backend: str | None,
    detail: dict[int, np.ndarray] | None = None,
) -> OffscreenRenderer:
    """A renderer whose context holds ``model`` with the simplified ``faces``
    (:func:`simplified_meshes`) and textures at most ``texture_cap`` wide; the mounted cameras
    among ``camera_ids`` are drawn without the mirror pass; ``detail``: see :mod:`.near`."""
    from libero_data.sim.distant import mounted_cameras, shrink_textures
    from libero_data.sim.hidden import HiddenGeoms, large_still_meshes
    from libero_data.sim.near import NearDetail
    from libero_data.sim.sky import SkyCover

    render_model = copy.deepcopy(model)
    for i, tri in faces.items():
        apply_faces(render_model, i, tri)
    shrink_textures(render_model, texture_cap)
    near = NearDetail(model, render_model, camera_ids, faces, detail) if detail else None
    mounted = mounted_cameras(model, camera_ids)
    hidden = HiddenGeoms(large_still_meshes(render_model)) if mounted else None
    sky = SkyCover(render_model)
    return OffscreenRenderer(
        render_model, size, backend, cull=True, unmirrored=mounted, detail=near, hidden=hidden, sky=sky
    )


def simplified_meshes(
    model: Any,
    camera_ids: list[int],
    settings: MeshSettings | None = None,
    cache_dir: str | Path | None = None,
    *,
    progress: bool | None = None,
    errors: dict[int, float] | None = None,
    reuse: dict[int, np.ndarray] | None = None,
) -> tuple[dict[int, np.ndarray], FastScene]:
    """The simplified triangles of the meshes ``model``'s cameras draw (from the cache, or built
    and cached), leaving whole those on the cameras' own bodies; mesh ``i`` within
    ``errors[i]`` metres where given, else ``settings.max_error``. ``reuse``: triangles already
    simplified at ``settings.max_error`` (an earlier call's), not looked up again."""
    settings = settings or MeshSettings()
    uses = drawn_meshes(model)
    near = camera_meshes(model, camera_ids)
    faces: dict[int, np.ndarray] = {}
    groups: dict[float, dict[int, MeshData]] = {}
    for i in sorted(set(uses) - near):
        error = (errors or {}).get(i, settings.max_error)
        if reuse is not None and error == settings.max_error:
            faces[i] = reuse[i]
        else:
            groups.setdefault(error, {})[i] = MeshData.from_model(model, i)
    report = CacheReport()
    for error, meshes in sorted(groups.items()):
        found, part = MeshCache(cache_dir).simplified(
            meshes, settings.replace(max_error=error), progress=progress
        )
        faces.update(found)
        report = report.merged(part)
    before = sum(n * int(model.mesh_facenum[i]) for i, n in uses.items())
    after = sum(n * (len(faces[i]) if i in faces else int(model.mesh_facenum[i])) for i, n in uses.items())
    scene = FastScene(
        faces_drawn_before=before,
        faces_drawn_after=after,
        meshes_simplified=sum(len(f) < int(model.mesh_facenum[i]) for i, f in faces.items()),
        meshes_kept_whole=len(set(uses) & near)
        + sum(len(f) == int(model.mesh_facenum[i]) for i, f in faces.items()),
        cache=report,
    )
    return faces, scene


class FastImages:
    """One environment's ``fast`` images, and full-quality references to measure them by.

    The simplified renderers are built on the first image (meshes from the cache, or simplified
    and cached): one for the mounted (wrist) cameras and, when there are fixed cameras too, one
    for those, whose distant meshes are coarser (:mod:`libero_data.sim.distant`; a GL context
    each). The reference renderer is built on the first reference image.
    """

    def __init__(self, size: int, camera_ids: list[int], backend: str | None, cache_dir: str | None) -> None:
        self.size, self.camera_ids, self.backend, self.cache_dir = size, camera_ids, backend, cache_dir
        self._fast: dict[int, tuple[OffscreenRenderer, FastScene]] | None = None  # camera id -> its renderer
        self._reference: OffscreenRenderer | None = None

    def _built(self, model: Any, camera_id: int | None = None) -> tuple[OffscreenRenderer, FastScene]:
        """The renderer of ``camera_id`` (default: the first camera's), built on first use."""
        if self._fast is None:
            self._fast = self._build(model)
        return self._fast[self.camera_ids[0] if camera_id is None else camera_id]

    def _build(self, model: Any) -> dict[int, tuple[OffscreenRenderer, FastScene]]:
        """The mounted cameras' renderer (0.5 mm meshes, textures up to 8x the image) and, where
        the fixed cameras have distant meshes to draw coarser or there is no mounted camera, the
        fixed cameras' own (textures up to 4x); otherwise the mounted cameras' serves all."""
        from libero_data.sim.distant import TEXTURE_PER_IMAGE, distant_errors, mounted_cameras
        from libero_data.sim.near import detailed_objects

        ids, size, cap = self.camera_ids, self.size, TEXTURE_PER_IMAGE
        faces, scene = simplified_meshes(model, ids, cache_dir=self.cache_dir)
        mounted = mounted_cameras(model, ids)
        fixed = [c for c in ids if c not in mounted]
        out: dict[int, tuple[OffscreenRenderer, FastScene]] = {}
        if mounted:
            detail, _ = detailed_objects(model, ids, cache_dir=self.cache_dir)
            near = (
                fast_renderer(model, size, ids, faces, cap["mounted"] * size, self.backend, detail),
                scene,
            )
            out.update(dict.fromkeys(mounted, near))
        errors = distant_errors(model, ids, size, drawn_geoms(model), MeshSettings().max_error)
        if fixed and mounted and not errors:
            out.update(dict.fromkeys(fixed, near))
        elif fixed:
            if errors:
                faces, scene = simplified_meshes(
                    model, ids, cache_dir=self.cache_dir, errors=errors, reuse=faces
                )
            far = (fast_renderer(model, size, ids, faces, cap["fixed"] * size, self.backend), scene)
            out.update(dict.fromkeys(fixed, far))
        return out

    def render(self, model: Any, data: Any, camera_id: int) -> np.ndarray:
        return self._built(model, camera_id)[0].render(model, data, camera_id)

    def render_timed(self, model: Any, data: Any, camera_id: int) -> dict[str, float]:
        """:meth:`OffscreenRenderer.render_timed` of the camera's ``fast`` renderer."""
        return self._built(model, camera_id)[0].render_timed(model, data, camera_id)

    def render_full(self, model: Any, data: Any, camera_id: int) -> np.ndarray:
        if self._reference is None:
            self._reference = OffscreenRenderer(model, self.size, self.backend)
        return self._reference.render(model, data, camera_id)

    def info(self) -> dict[str, Any]:
        from libero_data.sim.distant import SCREEN_ERROR_PX, TEXTURE_PER_IMAGE
        from libero_data.sim.near import NEAR_OBJECT_M

        out: dict[str, Any] = {
            "quality": "fast",
            "settings": {
                **MeshSettings().to_dict(),
                "algorithm": ALGORITHM,
                "reflections": "fixed cameras",
                "distant_meshes": f"{SCREEN_ERROR_PX} px (fixed cameras)",
                "near_objects": f"free objects within {NEAR_OBJECT_M} m of a mounted camera: normal weight"
                f" {MeshSettings().object_normal_weight}",
                "textures": ", ".join(f"at most {k}x the image ({c})" for c, k in TEXTURE_PER_IMAGE.items()),
            },
        }
        if self._fast is not None:  # triangles in the scene as each renderer holds it, the most
            scenes = [scene for _, scene in self._fast.values()]
            out.update(
                faces_before=scenes[0].faces_drawn_before,
                faces_after=max(s.faces_drawn_after for s in scenes),
            )
        return out

    def gl_info(self, model: Any) -> dict[str, str]:
        return self._built(model)[0].gl_info(self.backend)

    def close(self) -> None:
        renderers = {id(r): r for r, _ in (self._fast or {}).values()}
        for renderer in [*renderers.values(), self._reference]:
            if renderer is not None:
                renderer.close()
        self._fast = self._reference = None
