"""Which meshes ``fast`` simplifies, to what error, and the triangles a scene then draws.

:func:`simplified_meshes` asks the cache (:mod:`.meshes`) for the simplified triangles of every
mesh a model's cameras draw, except those on a mounted camera's own body and below it
(:func:`.cameras.camera_meshes`), grouped by the error each may take (:mod:`.distant` makes
the fixed cameras' distant meshes coarser), and counts the triangles per frame before and
after (:class:`FastScene`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.sim.fast.cameras import camera_meshes
from libero_data.sim.fast.meshes import CacheReport, MeshCache, MeshData, MeshSettings, drawn_meshes


@dataclass(frozen=True)
class FastScene:
    """What :func:`fast_renderer` draws: triangles per frame of all drawn geoms (a camera draws
    those in its view) at full and at fast quality, and the cache's work."""

    faces_drawn_before: int
    faces_drawn_after: int
    meshes_simplified: int
    meshes_kept_whole: int
    cache: CacheReport


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
