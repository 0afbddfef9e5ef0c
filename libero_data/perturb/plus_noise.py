"""LIBERO-Plus's image noise: severity 1-50 of a task's ``_noise_<n>`` picks one of five corruptions
(ImageNet-C's, with their own ten severities each) for the agentview image.

===========  ===============  ============================================================
``n``        corruption       per severity 1..10
===========  ===============  ============================================================
1-10         motion blur      ImageMagick's, radius and sigma (5, 2) .. (35, 20), angle
                              drawn in [-45, 45) degrees
11-20        Gaussian blur    sigma 1 .. 10 pixels
21-30        zoom blur        the image averaged with itself zoomed by each factor of
                              1 .. 1.1 (step 0.01) up to 1 .. 1.55 (step 0.03)
31-40        fog              a plasma fractal of strength 0.5 .. 5 (decay 3 .. 1.3) added
41-50        glass blur       blurred (sigma 0.5 .. 2.5), pixels replaced by a neighbour's
                              up to 1 .. 5 pixels away (3 .. 1 passes), blurred again
===========  ===============  ============================================================

The parameters are theirs (``envs/env_wrapper.py`` of their package); the code is ours. Randomness
comes from the generator the caller passes (their code draws from NumPy's global one). Two of
their habits are kept because their benchmark's images have them: glass blur's pass visits the
top-left 224 x 224 pixels only (ImageNet-C's image size) and copies a neighbour's pixel rather
than swapping the two; results are truncated to 8 bits, not rounded.
"""

from __future__ import annotations

from typing import Any

import numpy as np

MOTION = ((5, 2), (8, 3), (10, 4), (12, 5), (15, 6), (18, 8), (20, 10), (25, 12), (30, 15), (35, 20))
GAUSSIAN = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10)
ZOOM = (
    (1.11, 0.01),
    (1.16, 0.01),
    (1.21, 0.02),
    (1.26, 0.02),
    (1.31, 0.03),
    (1.36, 0.01),
    (1.41, 0.01),
    (1.46, 0.02),
    (1.51, 0.02),
    (1.56, 0.03),
)  # factors: numpy.arange(1, stop, step)
FOG = (
    (0.5, 3),
    (1.0, 2.8),
    (1.5, 2.5),
    (2.0, 2.2),
    (2.5, 2.0),
    (3.0, 1.8),
    (3.5, 1.6),
    (4.0, 1.5),
    (4.5, 1.4),
    (5.0, 1.3),
)
GLASS = (
    (0.5, 1, 3),
    (0.7, 1, 3),
    (0.9, 2, 3),
    (1.0, 2, 2),
    (1.1, 3, 2),
    (1.3, 3, 2),
    (1.5, 4, 2),
    (1.8, 4, 2),
    (2.2, 5, 1),
    (2.5, 5, 1),
)  # sigma, largest offset, passes
#: The corruptions in the order of their severities' tens.
NAMES = ("motion blur", "gaussian blur", "zoom blur", "fog", "glass blur")
GLASS_EXTENT = 224


def corruption(severity: int) -> tuple[str, int]:
    """The corruption and its own severity (1..10) of LIBERO-Plus's noise ``severity`` (1..50)."""
    if not 1 <= severity <= 50:
        raise ValueError(f"LIBERO-Plus noise severities are 1..50, not {severity}")
    return NAMES[(severity - 1) // 10], (severity - 1) % 10 + 1


def corrupt(image: np.ndarray, severity: int, rng: np.random.Generator) -> np.ndarray:
    """``image`` (H x W x 3, uint8) with LIBERO-Plus's noise ``severity``."""
    name, level = corruption(severity)
    x = np.ascontiguousarray(image, dtype=np.uint8)
    if name == "motion blur":
        return _motion_blur(x, *MOTION[level - 1], angle=float(rng.uniform(-45, 45)))
    if name == "gaussian blur":
        out = _gaussian(x / 255.0, GAUSSIAN[level - 1])
    elif name == "zoom blur":
        out = _zoom_blur(x, *ZOOM[level - 1])
    elif name == "fog":
        out = _fog(x, *FOG[level - 1], rng=rng)
    else:
        out = _glass_blur(x, *GLASS[level - 1], rng=rng)
    return (np.clip(out, 0, 1) * 255).astype(np.uint8)


def _gaussian(x: np.ndarray, sigma: float) -> np.ndarray:
    """Each channel blurred (edges repeated, kernel cut at 4 sigma): scikit-image's ``gaussian``."""
    from scipy.ndimage import gaussian_filter

    return np.asarray(gaussian_filter(x, sigma=(sigma, sigma, 0), mode="nearest", truncate=4.0))


def _motion_blur(x: np.ndarray, radius: float, sigma: float, *, angle: float) -> np.ndarray:
    try:
        from wand.image import Image
    except ImportError as exc:  # Wand present, ImageMagick's library missing
        from libero_data.errors import MissingFileError

        raise MissingFileError(
            f"LIBERO-Plus's motion-blur noise needs ImageMagick's library ({exc}); run scripts/setup"
        ) from None
    import io

    from PIL import Image as PILImage

    buffer = io.BytesIO()
    PILImage.fromarray(x).save(buffer, format="PNG")
    with Image(blob=buffer.getvalue()) as img:
        img.motion_blur(radius=radius, sigma=sigma, angle=angle)
        pixels = img.export_pixels(channel_map="RGB", storage="char")
        shape = (img.height, img.width, 3)
    return np.asarray(pixels, dtype=np.uint8).reshape(shape)


def _clipped_zoom(x: np.ndarray, factor: float) -> np.ndarray:
    from scipy.ndimage import zoom

    h = x.shape[0]
    crop = int(np.ceil(h / factor))
    top = (h - crop) // 2
    out = zoom(x[top : top + crop, top : top + crop], (factor, factor, 1), order=1)
    trim = (out.shape[0] - h) // 2
    return np.asarray(out[trim : trim + h, trim : trim + h])


def _zoom_blur(x: np.ndarray, stop: float, step: float) -> np.ndarray:
    image = (x / 255.0).astype(np.float32)
    factors = np.arange(1, stop, step)
    total = np.zeros_like(image)
    for factor in factors:
        total += _clipped_zoom(image, float(factor))
    return (image + total) / (len(factors) + 1)


def _plasma(size: int, decay: float, rng: np.random.Generator) -> np.ndarray:
    """A diamond-square height map in [0, 1], ``size`` a power of two."""
    grid = np.zeros((size, size))
    step = size
    wibble = 100.0

    def jitter(values: np.ndarray) -> Any:
        return values / 4 + wibble * rng.uniform(-wibble, wibble, values.shape)

    while step >= 2:
        half = step // 2
        corners = grid[0:size:step, 0:size:step]
        square = corners + np.roll(corners, -1, axis=0)
        square += np.roll(square, -1, axis=1)
        grid[half:size:step, half:size:step] = jitter(square)
        centres = grid[half:size:step, half:size:step]
        corners = grid[0:size:step, 0:size:step]
        left = centres + np.roll(centres, 1, axis=0) + corners + np.roll(corners, -1, axis=1)
        grid[0:size:step, half:size:step] = jitter(left)
        top = centres + np.roll(centres, 1, axis=1) + corners + np.roll(corners, -1, axis=0)
        grid[half:size:step, 0:size:step] = jitter(top)
        step //= 2
        wibble /= decay
    grid -= grid.min()
    return grid / grid.max()


def _fog(x: np.ndarray, strength: float, decay: float, *, rng: np.random.Generator) -> np.ndarray:
    image = x / 255.0
    peak = image.max()
    h, w = image.shape[:2]
    size = max(256, 1 << (max(h, w) - 1).bit_length())
    image = image + strength * _plasma(size, decay, rng)[:h, :w][..., np.newaxis]
    return image * peak / (peak + strength)


def _glass_blur(
    x: np.ndarray, sigma: float, offset: int, passes: int, *, rng: np.random.Generator
) -> np.ndarray:
    out = (_gaussian(x / 255.0, sigma) * 255).astype(np.uint8)
    extent = min(GLASS_EXTENT, out.shape[0], out.shape[1])
    rows = range(extent - offset, offset, -1)
    for _ in range(passes):
        moves = rng.integers(-offset, offset, size=(len(rows), len(rows), 2))
        for i, h in enumerate(rows):
            for j, w in enumerate(rows):
                dx, dy = moves[i, j]
                out[h, w] = out[h + dy, w + dx]
    return _gaussian(out / 255.0, sigma)
