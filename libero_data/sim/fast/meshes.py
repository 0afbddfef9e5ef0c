"""Simplified copies of a scene's visual meshes, built once per mesh and kept in a cache.

Most of the triangles of a LIBERO camera frame lie in a few finely tessellated meshes (the
bowls, the robot's links) that cover a few hundred pixels of a 128x128 image, and on a CPU
(llvmpipe) a frame's cost follows the triangles it draws (benchmarks/RESULTS.md, Fast
rendering, where the triangles per scene are counted at both qualities).
``render_quality="fast"`` draws simplified copies instead:

- every mesh above :attr:`MeshSettings.min_faces` is simplified by edge collapse
  (meshoptimizer) until no collapse keeps the surface within :attr:`MeshSettings.max_error`
  metres of the original, with texture coordinates and normals weighted into the error;
- the simplified triangles keep the original vertices, so positions, texture coordinates and
  normals are the original values (each corner takes, among the original corners at its
  vertex, the normal closest to the new face's), and the mesh's placement, inertia and
  collision geometry are untouched (only what is drawn changes);
- the result of each mesh is cached under a key made of the mesh's own arrays, the settings,
  this module's algorithm version and meshoptimizer's version: a mesh shared by many scenes is
  simplified once, and a change of any of these rebuilds it.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.config import Config
from libero_data.runtime.files import cache_root

#: Bumped whenever :func:`simplify_mesh` changes what it returns for the same input.
ALGORITHM = 1
#: The cache's folder name under its root (a new algorithm family gets a new folder).
CACHE_FOLDER = "render-meshes-v1"
#: Geom groups robosuite draws (``render_collision_mesh=False``, ``render_visual_mesh=True``):
#: group 0 holds collision geometry, group 1 visual meshes, group 2 what MuJoCo shows by default.
DRAWN_GROUPS = (1, 2)


@dataclass(frozen=True)
class MeshSettings(Config):
    """How visual meshes are simplified for ``render_quality="fast"``.

    ``max_error`` is a distance in metres: 0.5 mm is under a third of a pixel for an object
    30 cm from the wrist camera at 128x128, and a tenth of one at the agentview camera.
    ``texcoord_weight`` and ``normal_weight`` scale how much a change of texture coordinate or
    normal counts against ``max_error`` beside the change of shape. Weighed lightly, texture
    coordinates drift far enough that the wood of a table or the print on a bowl slides under
    the wrist camera: the image then differs from ``full`` inside surfaces, not along
    silhouettes, by more than :data:`~libero_data.sim.fast.images.FAST_MEAN_BOUND`. Texture
    coordinates are therefore weighed heavily, which keeps few more triangles than a light
    weight does (benchmarks/RESULTS.md, Fast rendering: texture coordinates drifted).

    ``object_normal_weight`` replaces ``normal_weight`` in the detailed copies of free objects'
    meshes (bodies on a free joint: what the tasks move) that a mounted camera draws while it is
    near them (:class:`~libero_data.sim.fast.near.NearDetail`). A few centimetres from the wrist
    camera a drifted normal moves the shading inside the object, which then fills much of the
    frame: pushing the gripper down onto a bowl, nearly all of the wrist image's |fast - full|
    lies inside the bowl and passes the bound at ``normal_weight``, not at this weight. Every
    free object at this weight all the time would draw many more triangles in every frame,
    hence only near (benchmarks/RESULTS.md, Fast rendering: normals drifted on objects right
    under the wrist camera).
    """

    max_error: float = 0.0005
    texcoord_weight: float = 10.0
    normal_weight: float = 0.1
    object_normal_weight: float = 1.0
    min_faces: int = 64  # meshes with at most this many triangles are drawn as they are

    def __post_init__(self) -> None:
        if not 0.0 < self.max_error < 0.1:
            self._fail("max_error", "must be in (0, 0.1) metres")
        for name in ("texcoord_weight", "normal_weight", "object_normal_weight"):
            if getattr(self, name) < 0:
                self._fail(name, "must be >= 0")
        self._check_positive("min_faces")


@dataclass(frozen=True)
class MeshData:
    """One compiled mesh: MuJoCo's arrays, each face corner indexing vertices, normals, texcoords."""

    vert: np.ndarray  # (nv, 3) float32
    normal: np.ndarray  # (nn, 3) float32
    texcoord: np.ndarray  # (nt, 2) float32, empty without texture coordinates
    face: np.ndarray  # (nf, 3) int32 into vert
    facenormal: np.ndarray  # (nf, 3) int32 into normal
    facetexcoord: np.ndarray  # (nf, 3) int32 into texcoord

    @classmethod
    def from_model(cls, model: Any, i: int) -> MeshData:
        """Mesh ``i`` of a compiled ``mujoco.MjModel`` (copies)."""

        def block(values: np.ndarray, adr: Any, num: Any) -> np.ndarray:
            return np.array(values[int(adr) : int(adr) + int(num)], copy=True)

        fa, fn = model.mesh_faceadr[i], model.mesh_facenum[i]
        return cls(
            vert=block(model.mesh_vert, model.mesh_vertadr[i], model.mesh_vertnum[i]),
            normal=block(model.mesh_normal, model.mesh_normaladr[i], model.mesh_normalnum[i]),
            texcoord=block(model.mesh_texcoord, model.mesh_texcoordadr[i], model.mesh_texcoordnum[i]),
            face=block(model.mesh_face, fa, fn),
            facenormal=block(model.mesh_facenormal, fa, fn),
            facetexcoord=block(model.mesh_facetexcoord, fa, fn),
        )

    @property
    def faces(self) -> int:
        return int(self.face.shape[0])

    def key(self, settings: MeshSettings) -> str:
        """The cache key: these arrays, the settings :func:`simplify_mesh` reads and the code
        that simplifies them (which meshes take ``object_normal_weight`` is the caller's choice,
        made by passing it as ``normal_weight``)."""
        from libero_data.sim.fast import meshopt

        digest = hashlib.sha256()
        used = {k: v for k, v in settings.to_dict().items() if k != "object_normal_weight"}
        recipe = {"algorithm": ALGORITHM, "meshoptimizer": meshopt.version(), "settings": used}
        digest.update(json.dumps(recipe, sort_keys=True).encode())
        for array in (self.vert, self.normal, self.texcoord, self.face, self.facenormal, self.facetexcoord):
            digest.update(str(array.shape).encode())
            digest.update(np.ascontiguousarray(array).tobytes())
        return digest.hexdigest()[:32]


def simplify_mesh(mesh: MeshData, settings: MeshSettings) -> np.ndarray:
    """The simplified triangles of ``mesh``: ``(k, 3, 3)`` int32, corner -> (vertex, normal, texcoord).

    Corners are grouped into *wedges* by position and texture coordinate (by value: MuJoCo
    keeps a vertex per face corner for many meshes), so the simplifier sees the surface's
    real topology and keeps texture seams. A mesh the simplifier cannot reduce comes back whole.
    """
    from libero_data.sim.fast import meshopt

    whole = np.stack([mesh.face, mesh.facenormal, mesh.facetexcoord], axis=-1).astype(np.int32)
    if mesh.faces <= settings.min_faces:
        return whole
    corner_vert = mesh.face.reshape(-1)
    corner_normal = mesh.normal[mesh.facenormal.reshape(-1)].astype(np.float64)
    has_tex = mesh.texcoord.shape[0] > 0
    tex = mesh.texcoord[mesh.facetexcoord.reshape(-1)] if has_tex else np.zeros((corner_vert.size, 2))
    key = np.concatenate([mesh.vert[corner_vert], tex], axis=1)
    wedges, wedge_of = np.unique(key, axis=0, return_inverse=True)
    wedge_of = wedge_of.reshape(-1)
    normals = np.zeros((len(wedges), 3))
    np.add.at(normals, wedge_of, corner_normal)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True) + 1e-12
    tw, nw = settings.texcoord_weight, settings.normal_weight
    kept = meshopt.simplify(
        wedge_of,
        wedges[:, :3],
        np.concatenate([wedges[:, 3:5], normals], axis=1),
        np.array([tw, tw, nw, nw, nw]),
        target_error=settings.max_error,
        min_triangles=settings.min_faces,
    ).reshape(-1, 3)
    if len(kept) == 0 or len(kept) >= mesh.faces:
        return whole
    corners = _best_corners(kept, wedge_of, wedges[:, :3], corner_normal)
    return whole.reshape(-1, 3)[corners]


def _best_corners(
    triangles: np.ndarray, wedge_of: np.ndarray, positions: np.ndarray, corner_normal: np.ndarray
) -> np.ndarray:
    """For each corner of each new triangle, the original corner (of its wedge) to copy.

    Among the original corners that share the wedge, the one whose normal is closest to the
    new face's normal: a hard edge stays hard, a smooth surface stays smooth.
    """
    p = positions[triangles]
    face_normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    face_normal /= np.linalg.norm(face_normal, axis=1, keepdims=True) + 1e-12
    order = np.argsort(wedge_of, kind="stable")
    starts = np.searchsorted(wedge_of[order], np.arange(len(positions)))
    counts = np.diff(np.append(starts, len(order)))
    best = np.empty(triangles.shape, dtype=np.int64)
    rows = np.arange(len(triangles))
    for c in range(3):
        w = triangles[:, c]
        width = int(counts[w].max())
        offsets = np.minimum(np.arange(width)[None, :], (counts[w] - 1)[:, None])
        candidates = order[starts[w][:, None] + offsets]
        dots = np.einsum("tcj,tj->tc", corner_normal[candidates], face_normal)
        best[:, c] = candidates[rows, dots.argmax(axis=1)]
    return best


@dataclass
class CacheReport:
    """What one scene's lookup did: meshes found, built, kept whole; triangles before/after."""

    found: int = 0
    built: int = 0
    whole: int = 0
    faces_before: int = 0
    faces_after: int = 0
    build_seconds: float = 0.0
    keys: list[str] = field(default_factory=list)

    def merged(self, other: CacheReport) -> CacheReport:
        """Both lookups' work together."""
        return CacheReport(
            found=self.found + other.found,
            built=self.built + other.built,
            whole=self.whole + other.whole,
            faces_before=self.faces_before + other.faces_before,
            faces_after=self.faces_after + other.faces_after,
            build_seconds=self.build_seconds + other.build_seconds,
            keys=self.keys + other.keys,
        )


class MeshCache:
    """Simplified meshes on disk, one ``.npz`` per key, written atomically (safe across workers)."""

    def __init__(self, root: str | Path | None = None) -> None:
        self.folder = cache_root(root) / CACHE_FOLDER

    def path(self, key: str) -> Path:
        return self.folder / f"{key}.npz"

    def load(self, key: str) -> np.ndarray | None:
        """The cached triangles of ``key``, or None when absent or unreadable (then rebuilt)."""
        path = self.path(key)
        if not path.is_file():
            return None
        try:
            with np.load(path) as data:
                faces = np.asarray(data["faces"], dtype=np.int32)
        except Exception:  # a truncated or foreign file is rebuilt, never trusted
            return None
        return faces if faces.ndim == 3 and faces.shape[1:] == (3, 3) else None

    def store(self, key: str, faces: np.ndarray) -> None:
        from libero_data.runtime.files import save_npz

        save_npz(self.path(key), faces=np.asarray(faces, dtype=np.int32))

    def simplified(
        self,
        meshes: dict[int, MeshData],
        settings: MeshSettings,
        *,
        progress: bool | None = None,
    ) -> tuple[dict[int, np.ndarray], CacheReport]:
        """Simplified triangles of every mesh, from the cache or built (with a progress bar) and stored."""
        report = CacheReport()
        out: dict[int, np.ndarray] = {}
        missing: list[tuple[int, str]] = []
        for i, mesh in meshes.items():
            key = mesh.key(settings)
            report.keys.append(key)
            faces = self.load(key)
            if faces is None:
                missing.append((i, key))
            else:
                out[i] = faces
                report.found += 1
        start = time.perf_counter()
        for i, key in _progress(missing, progress):
            out[i] = simplify_mesh(meshes[i], settings)
            self.store(key, out[i])
            report.built += 1
        report.build_seconds = time.perf_counter() - start
        for i, mesh in meshes.items():
            report.faces_before += mesh.faces
            report.faces_after += len(out[i])
            report.whole += int(len(out[i]) == mesh.faces)
        return out, report


def _progress(items: list[tuple[int, str]], show: bool | None) -> Iterable[tuple[int, str]]:
    if not items or show is False:
        return items
    from tqdm import tqdm

    # show=None: a bar on a terminal only (worker processes and logs stay quiet).
    return tqdm(
        items,
        desc="simplifying meshes (once, then cached)",
        unit="mesh",
        disable=None if show is None else False,
        leave=False,
    )


def apply_faces(model: Any, i: int, faces: np.ndarray, capacity: int | None = None) -> None:
    """Replace mesh ``i``'s triangles in ``model`` (a render copy) by ``faces`` (k, 3, 3);
    ``capacity``: its triangles as compiled (default: its count now, fewer once simplified)."""
    adr = int(model.mesh_faceadr[i])
    num = int(model.mesh_facenum[i]) if capacity is None else capacity
    k = len(faces)
    if k > num:
        raise ValueError(f"mesh {i} has {num} triangles; a simplified copy cannot have {k}")
    model.mesh_face[adr : adr + k] = faces[:, :, 0]
    model.mesh_facenormal[adr : adr + k] = faces[:, :, 1]
    model.mesh_facetexcoord[adr : adr + k] = faces[:, :, 2]
    model.mesh_facenum[i] = k


def drawn_meshes(model: Any) -> dict[int, int]:
    """Mesh -> how many of the geoms a camera draws use it (visible groups, not fully transparent)."""
    import mujoco

    is_mesh = model.geom_type == mujoco.mjtGeom.mjGEOM_MESH
    ids, counts = np.unique(model.geom_dataid[is_mesh & drawn_geoms(model)], return_counts=True)
    return {int(i): int(n) for i, n in zip(ids, counts, strict=True)}


def drawn_geoms(model: Any) -> np.ndarray:
    """Per geom: whether a camera draws it (a visible group, not fully transparent)."""
    return np.isin(model.geom_group, DRAWN_GROUPS) & (model.geom_rgba[:, 3] > 0)
