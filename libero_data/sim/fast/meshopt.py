"""meshoptimizer's mesh simplifier, called through its C library.

The ``meshoptimizer`` package ships the C library as a shared object beside its Python code;
its own wrapper does not declare the argument types of ``meshopt_simplifyWithAttributes``.
This module loads the same shared object under its own handle (so the package's function
objects are left as they are) and declares the one function it calls. Loaded on first use.
"""

from __future__ import annotations

import ctypes
import functools
import importlib.metadata
import importlib.util
from pathlib import Path

import numpy as np

from libero_data.errors import RenderBackendError

#: ``meshopt_SimplifyErrorAbsolute``: the target error is a distance in the mesh's units.
ERROR_ABSOLUTE = 1 << 2


@functools.cache
def _library() -> ctypes.CDLL:
    spec = importlib.util.find_spec("meshoptimizer")
    folders = list(spec.submodule_search_locations or []) if spec is not None else []
    found = [p for folder in folders for p in sorted(Path(folder).glob("_meshoptimizer*.so"))]
    if not found:
        raise RenderBackendError(
            "render_quality 'fast' needs the meshoptimizer package (its C library), which is not "
            "installed; run scripts/setup or: pip install meshoptimizer==0.2.30a0"
        )
    lib = ctypes.CDLL(str(found[0]))
    fn = lib.meshopt_simplifyWithAttributes
    p, n = ctypes.c_void_p, ctypes.c_size_t
    fn.argtypes = [p, p, n, p, n, n, p, n, p, n, p, n, ctypes.c_float, ctypes.c_uint, p]
    fn.restype = n
    return lib


def version() -> str:
    """The installed meshoptimizer package's version (part of every cache key)."""
    try:
        return importlib.metadata.version("meshoptimizer")
    except importlib.metadata.PackageNotFoundError:
        return "missing"


def simplify(
    indices: np.ndarray,
    positions: np.ndarray,
    attributes: np.ndarray,
    weights: np.ndarray,
    *,
    target_error: float,
    min_triangles: int,
) -> np.ndarray:
    """Indices of a simplified triangle list over the same vertices.

    ``indices`` (3 per triangle) index ``positions`` (n, 3); ``attributes`` (n, k) with
    ``weights`` (k) shape the error as well (texture coordinates, normals). Edges are collapsed
    until no further collapse keeps the surface within ``target_error`` (absolute, in the
    units of ``positions``) or ``min_triangles`` remain. Vertices that share a position are
    one vertex to the topology (attribute seams stay intact).
    """
    fn = _library().meshopt_simplifyWithAttributes
    idx = np.ascontiguousarray(indices, dtype=np.uint32).reshape(-1)
    pos = np.ascontiguousarray(positions, dtype=np.float32)
    attrs = np.ascontiguousarray(attributes, dtype=np.float32)
    w = np.ascontiguousarray(weights, dtype=np.float32)
    if pos.ndim != 2 or pos.shape[1] != 3 or attrs.shape != (len(pos), len(w)) or idx.size % 3:
        raise ValueError(
            "simplify needs (n, 3) positions, (n, k) attributes, k weights and 3 indices per triangle"
        )
    dest = np.empty_like(idx)
    result_error = ctypes.c_float(0.0)
    count = fn(
        dest.ctypes.data,
        idx.ctypes.data,
        idx.size,
        pos.ctypes.data,
        len(pos),
        pos.itemsize * 3,
        attrs.ctypes.data,
        attrs.itemsize * attrs.shape[1],
        w.ctypes.data,
        len(w),
        None,
        3 * min_triangles,
        float(target_error),
        ERROR_ABSOLUTE,
        ctypes.byref(result_error),
    )
    return dest[:count].copy()
