"""Textures halved for fast rendering: summed in integers, the same bytes as halving in float
level by level (the definition), on any shape and cap."""

from __future__ import annotations

import numpy as np
import pytest

from libero_data.sim.fast.texture_size import halved


def halved_in_float(image: np.ndarray, cap: int) -> np.ndarray:
    """The definition: 2x2 means in float32, level by level, rounded at the end."""
    out = image.astype(np.float32)
    channels = out.shape[2]
    while max(out.shape[:2]) > cap and out.shape[0] % 2 == 0 and out.shape[1] % 2 == 0:
        h, w = out.shape[0] // 2, out.shape[1] // 2
        out = out.reshape(h, 2, w, 2, channels).mean(axis=(1, 3))
    return np.round(out).astype(np.uint8)


@pytest.mark.parametrize(
    ("shape", "cap"),
    [((256, 256, 3), 16), ((192, 128, 3), 16), ((120, 128, 4), 8), ((64, 64, 3), 100), ((512, 64, 3), 4)],
)
def test_halving_in_integers_gives_the_bytes_of_halving_in_float(shape: tuple[int, ...], cap: int) -> None:
    image = np.random.default_rng(sum(shape) + cap).integers(0, 256, shape, dtype=np.uint8)
    expected = halved_in_float(image, cap)
    got = halved(image, cap)
    assert got.dtype == np.uint8 and got.shape == expected.shape
    np.testing.assert_array_equal(got, expected)
    ties = np.full((16, 16, 3), 0, np.uint8)
    ties[::2, ::2] = 1  # every 2x2 block means 0.25, every 4x4 block 0.25: rounding as defined
    ties[0, 0] = 3
    np.testing.assert_array_equal(halved(ties, 4), halved_in_float(ties, 4))
