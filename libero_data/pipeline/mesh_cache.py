"""Building the simplified-mesh cache of ``render_quality="fast"`` for many tasks at once
(``libero-data render-cache``), so that no later run pays for it.

Each task's scene is built without cameras (no GL context is needed to simplify meshes); a
mesh shared by several scenes is simplified once, the first time it is met.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any


@dataclass
class CacheBuild:
    """What building the cache for a set of tasks did."""

    tasks: int = 0
    meshes_built: int = 0
    meshes_found: int = 0
    triangles_full: list[int] = field(default_factory=list)  # per scene, all drawn geoms
    triangles_fast: list[int] = field(default_factory=list)
    seconds: float = 0.0
    simplify_seconds: float = 0.0


def build_mesh_cache(
    tasks: Iterable[Any],
    cache_dir: str | Path | None = None,
    on_task: Callable[[Any, CacheBuild], None] | None = None,
    image_sizes: Iterable[int] = (128,),
) -> CacheBuild:
    """Simplify (or find in the cache) the drawn meshes of every task's scene, and the coarser
    copies of its distant meshes that the fixed cameras draw at each of ``image_sizes``."""
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.sim.env import CAMERAS
    from libero_data.sim.fast.distant import distant_errors
    from libero_data.sim.fast.meshes import MeshSettings, drawn_geoms
    from libero_data.sim.fast.near import detailed_objects
    from libero_data.sim.fast.simplify import simplified_meshes

    build = CacheBuild()
    start = time.perf_counter()
    for task in tasks:
        with LiberoEnv(task, EnvConfig(cameras=())) as env:
            model = env.sim.model._model
            ids = [int(env.sim.model.camera_name2id(name)) for name in CAMERAS.values()]
            faces, scene = simplified_meshes(model, ids, cache_dir=cache_dir, progress=False)
            _, detail = detailed_objects(model, ids, cache_dir=cache_dir, progress=False)
            build.meshes_built += detail.built
            build.simplify_seconds += detail.build_seconds
            for size in image_sizes:
                errors = distant_errors(model, ids, size, drawn_geoms(model), MeshSettings().max_error)
                _, far = simplified_meshes(
                    model, ids, cache_dir=cache_dir, progress=False, errors=errors, reuse=faces
                )
                build.meshes_built += far.cache.built
                build.simplify_seconds += far.cache.build_seconds
        build.tasks += 1
        build.meshes_built += scene.cache.built
        build.meshes_found += scene.cache.found
        build.simplify_seconds += scene.cache.build_seconds
        build.triangles_full.append(scene.faces_drawn_before)
        build.triangles_fast.append(scene.faces_drawn_after)
        build.seconds = time.perf_counter() - start
        if on_task is not None:
            on_task(task, build)
    return build
