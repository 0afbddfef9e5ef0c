"""``libero-data render-cache`` (through :func:`build_mesh_cache`): a scene's simplified meshes,
and the fixed cameras' coarser distant ones, are built once and then found."""

from __future__ import annotations

import pytest

from libero_data.pipeline.mesh_cache import build_mesh_cache
from libero_data.tasks import get_task

pytestmark = pytest.mark.sim


def test_the_cache_is_built_once_for_the_meshes_and_the_distant_copies(tmp_path) -> None:
    task = get_task("libero_90/0")
    first = build_mesh_cache([task], tmp_path, image_sizes=(128,))
    assert first.tasks == 1 and first.meshes_built > 0 and first.triangles_fast[0] < first.triangles_full[0]
    base = build_mesh_cache([task], tmp_path, image_sizes=())  # the 0.5 mm copies alone
    assert base.meshes_built == 0 and base.meshes_found > 0
    distant = set((tmp_path / "render-meshes-v1").iterdir())
    again = build_mesh_cache([task], tmp_path, image_sizes=(128,))
    assert again.meshes_built == 0
    assert set((tmp_path / "render-meshes-v1").iterdir()) == distant
    bigger = build_mesh_cache([task], tmp_path, image_sizes=(256,))  # other sizes, other copies
    assert bigger.meshes_built > 0
