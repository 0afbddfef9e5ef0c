"""``render_quality="fast"``: one environment's images, each camera from the renderer that suits it.

:func:`fast_renderer` builds one :class:`~.renderer.OffscreenRenderer` from a copy of the model
whose meshes are simplified (:mod:`.simplify`, cached) and whose textures are capped
(:mod:`.texture_size`); the mounted (wrist) cameras are drawn without MuJoCo's mirror pass
(:func:`.cameras.mounted_cameras`), and the sky only where it may show (:mod:`.sky`).
:class:`FastImages` chooses per camera: one renderer for the mounted cameras and, where the
fixed cameras have distant meshes to draw coarser (:mod:`.distant`), one of their own; and a
full-quality reference renderer that ``fast`` images are measured against.
"""

from __future__ import annotations

import copy
import hashlib
import threading
from typing import Any

import numpy as np

from libero_data.sim.fast.cameras import mounted_cameras
from libero_data.sim.fast.distant import SCREEN_ERROR_PX, distant_errors
from libero_data.sim.fast.hidden import HiddenGeoms, large_still_meshes
from libero_data.sim.fast.meshes import ALGORITHM, MeshSettings, apply_faces, drawn_geoms
from libero_data.sim.fast.near import NEAR_OBJECT_M, NearDetail, detailed_objects
from libero_data.sim.fast.renderer import OffscreenRenderer
from libero_data.sim.fast.simplify import FastScene, simplified_meshes
from libero_data.sim.fast.sky import SkyCover
from libero_data.sim.fast.texture_size import TEXTURE_PER_IMAGE, shrink_textures

#: The largest mean |fast - full| per camera image (0-1 scale) that ``fast`` is held to. Measured
#: on one scene of each suite at 128 and 256 px: 0.0015-0.0085, always below the error the
#: datasets' AV1 encoding adds to the same full-quality frames (0.0076-0.0120); see "Fast
#: rendering" in benchmarks/RESULTS.md.
FAST_MEAN_BOUND = 0.01


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
    (:func:`.simplify.simplified_meshes`) and textures at most ``texture_cap`` wide; the mounted cameras
    among ``camera_ids`` are drawn without the mirror pass; ``detail``: see :mod:`.near`."""
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


#: The renderers of the environments that share them, by what they were built for (see
#: :class:`FastImages`): [camera id -> (renderer, scene), environments using them].
_SHARED: dict[tuple[Any, ...], list[Any]] = {}


#: Model arrays that a reset changes (LIBERO places its fixtures by their bodies' positions;
#: site colours), left out of :func:`scene_key`: one environment draws across its resets too.
RESET_FIELDS = frozenset({"body_pos", "site_rgba"})
#: Arrays larger than this (bytes: textures, meshes) enter :func:`scene_key` by a strided sample.
SAMPLED_ABOVE = 1 << 16


def scene_key(model: Any) -> str:
    """What a scene's renderers are built from, as 32 hex digits: every array of the compiled
    model but those a reset changes (:data:`RESET_FIELDS`), the large ones by a sample of every
    1,021st byte (a texture or mesh swapped for another of the same size differs in nearly
    every byte), and the model's names. Two builds of one task (and perturbation) agree.
    """
    digest = hashlib.blake2b(digest_size=16)
    for name in sorted(dir(model)):
        if name.startswith("_") or name in RESET_FIELDS:
            continue
        value = getattr(model, name)
        if not isinstance(value, np.ndarray):
            continue
        data = np.ascontiguousarray(value).reshape(-1).view(np.uint8)
        digest.update(f"{name}:{value.dtype}:{value.shape}".encode())
        digest.update(np.ascontiguousarray(data[::1021]) if data.nbytes > SAMPLED_ABOVE else data)
    digest.update(bytes(model.names))
    return digest.hexdigest()


class FastImages:
    """One environment's ``fast`` images, and full-quality references to measure them by.

    The simplified renderers are built on the first image (meshes from the cache, or simplified
    and cached): one for the mounted (wrist) cameras and, when there are fixed cameras too, one
    for those, whose distant meshes are coarser (:mod:`.distant`; a GL context each). The
    reference renderer is built on the first reference image. :meth:`renderer` and
    :meth:`fast_scene` name each camera's renderer and what it draws (for tests and benchmarks).

    Environments of one thread whose scenes are the same (:func:`scene_key`: a worker's
    environments of one task), at the same size, cameras, backend and cache, share one set of
    renderers, built once and closed with the last of them. An image depends on the simulated
    state alone, never on what was drawn before it (:class:`.near.NearDetail`), so sharing is
    what one environment does across its resets; a GL context is current in one thread at a
    time, hence one set per thread.
    """

    def __init__(self, size: int, camera_ids: list[int], backend: str | None, cache_dir: str | None) -> None:
        self.size, self.camera_ids, self.backend, self.cache_dir = size, camera_ids, backend, cache_dir
        self._renderers: dict[int, tuple[OffscreenRenderer, FastScene]] | None = None  # camera id -> its own
        self._shared_as: tuple[Any, ...] | None = None
        self._reference: OffscreenRenderer | None = None

    def renderer(self, model: Any, camera_id: int | None = None) -> OffscreenRenderer:
        """The ``fast`` renderer that draws camera ``camera_id`` (default: the first camera), built
        on first use from ``model``; cameras may share one."""
        return self._built(model, camera_id)[0]

    def fast_scene(self, model: Any, camera_id: int | None = None) -> FastScene:
        """The triangles :meth:`renderer`'s context holds for ``camera_id``, and its cache's work."""
        return self._built(model, camera_id)[1]

    def _built(self, model: Any, camera_id: int | None) -> tuple[OffscreenRenderer, FastScene]:
        if self._renderers is None:
            key = (
                threading.get_ident(), scene_key(model), self.size, tuple(self.camera_ids),
                self.backend, self.cache_dir,
            )  # fmt: skip
            entry = _SHARED.get(key)
            if entry is None:
                entry = _SHARED[key] = [self._build(model), 0]
            entry[1] += 1
            self._renderers, self._shared_as = entry[0], key
        return self._renderers[self.camera_ids[0] if camera_id is None else camera_id]

    def _build(self, model: Any) -> dict[int, tuple[OffscreenRenderer, FastScene]]:
        """The mounted cameras' renderer (0.5 mm meshes, textures up to 8x the image) and, where
        the fixed cameras have distant meshes to draw coarser or there is no mounted camera, the
        fixed cameras' own (textures up to 4x); otherwise the mounted cameras' serves all."""
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
        return self.renderer(model, camera_id).render(model, data, camera_id)

    def render_full(self, model: Any, data: Any, camera_id: int) -> np.ndarray:
        if self._reference is None:
            self._reference = OffscreenRenderer(model, self.size, self.backend)
        return self._reference.render(model, data, camera_id)

    def info(self) -> dict[str, Any]:
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
        if self._renderers is not None:  # triangles in the scene as each renderer holds it, the most
            scenes = [scene for _, scene in self._renderers.values()]
            out.update(
                faces_before=scenes[0].faces_drawn_before,
                faces_after=max(s.faces_drawn_after for s in scenes),
            )
        return out

    def gl_info(self, model: Any) -> dict[str, str]:
        return self.renderer(model).gl_info(self.backend)

    def close(self) -> None:
        """Close this environment's renderers (shared ones once their last environment closes)."""
        renderers = {id(r): r for r, _ in (self._renderers or {}).values()}
        if self._shared_as is not None:
            entry = _SHARED[self._shared_as]
            entry[1] -= 1
            if entry[1] > 0:
                renderers = {}
            else:
                del _SHARED[self._shared_as]
            self._shared_as = None
        for renderer in [*renderers.values(), self._reference]:
            if renderer is not None:
                renderer.close()
        self._renderers = self._reference = None
