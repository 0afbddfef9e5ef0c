"""``libero-data render-cache``: simplify the visual meshes of many tasks at once, for
``--render-quality fast`` (which otherwise does it per scene, the first time it is drawn)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from libero_data.cli.common import progress, say, split_list, user_errors


@user_errors
def render_cache_cmd(
    suites: Annotated[
        list[str] | None,
        typer.Option(
            "--suite",
            "-s",
            help="Suites (names or folders) whose scenes to prepare; repeat or comma-separate. "
            "Default: the five LIBERO suites (130 tasks).",
        ),
    ] = None,
    cache: Annotated[
        Path | None,
        typer.Option(
            "--cache",
            help="Cache folder; default $LIBERO_DATA_CACHE, else ~/.cache/libero-data (as the renderer uses).",
        ),
    ] = None,
    image_size: Annotated[
        list[int] | None,
        typer.Option(
            "--image-size",
            help="Image sizes to prepare the fixed cameras' coarser distant meshes for (they depend on "
            "the size); repeat for several. Default: 128.",
        ),
    ] = None,
) -> None:
    """Build the simplified-mesh cache that `--render-quality fast` draws from, for every task of the suites.

    Meshes already in the cache (same mesh, same settings, same simplifier) are reused; a change of
    any of them builds a new entry. Safe to interrupt and run again.
    """
    from libero_data.pipeline.mesh_cache import CacheBuild, build_mesh_cache
    from libero_data.sim.fast.meshes import CACHE_FOLDER, cache_root
    from libero_data.tasks import get_suite

    names = split_list(suites) or ["libero_spatial", "libero_object", "libero_goal", "libero_10", "libero_90"]
    tasks = [t for name in names for t in get_suite(name).tasks]
    with progress("meshes") as bar:
        job = bar.add_task("scenes", total=len(tasks), meshes="")

        def seen(task: object, b: CacheBuild) -> None:
            bar.update(job, advance=1, meshes=f"{b.meshes_built} built, {b.meshes_found} found")

        build = build_mesh_cache(tasks, cache, on_task=seen, image_sizes=image_size or [128])
    folder = cache_root(cache) / CACHE_FOLDER
    size = sum(p.stat().st_size for p in folder.glob("*.npz")) if folder.is_dir() else 0
    full, fast = build.triangles_full, build.triangles_fast
    say(
        f"{build.tasks} scenes in {build.seconds:.0f} s ({build.simplify_seconds:.0f} s simplifying): "
        f"{build.meshes_built} meshes simplified, {build.meshes_found} found in the cache"
    )
    if full:
        say(
            f"triangles per scene: full {min(full) / 1000:.0f}-{max(full) / 1000:.0f} k, "
            f"fast {min(fast) / 1000:.0f}-{max(fast) / 1000:.0f} k "
            f"(mean {sum(fast) / sum(full):.0%} of full)"
        )
    say(f"cache: {folder} ({size / 1e6:.1f} MB)")
