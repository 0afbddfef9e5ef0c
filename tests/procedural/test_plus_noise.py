"""LIBERO-Plus's five image corruptions at their severities: each changes the image, the same
generator gives the same image, and severities map to corruptions as their code maps them."""

from __future__ import annotations

import numpy as np
import pytest

from libero_data.perturb.plus_noise import NAMES, corrupt, corruption


def _image() -> np.ndarray:
    rng = np.random.default_rng(3)
    image = np.full((128, 128, 3), 90, dtype=np.uint8)
    image[32:96, 40:88] = (200, 60, 40)
    return np.clip(image + rng.integers(0, 20, image.shape), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("severity", [1, 10, 11, 20, 21, 30, 31, 40, 41, 50])
def test_each_corruption_changes_the_image_reproducibly(severity: int) -> None:
    image = _image()
    out = corrupt(image, severity, np.random.default_rng(7))
    assert out.shape == image.shape and out.dtype == np.uint8
    assert np.abs(out.astype(int) - image).mean() > 1.0
    assert np.array_equal(out, corrupt(image, severity, np.random.default_rng(7)))


def test_severities_map_to_their_corruptions() -> None:
    assert [corruption(n) for n in (1, 10, 11, 25, 40, 41, 50)] == [
        ("motion blur", 1),
        ("motion blur", 10),
        ("gaussian blur", 1),
        ("zoom blur", 5),
        ("fog", 10),
        ("glass blur", 1),
        ("glass blur", 10),
    ]
    assert len(NAMES) == 5
    with pytest.raises(ValueError, match=r"1\.\.50"):
        corruption(51)


def test_stronger_blur_is_blurrier() -> None:
    image = _image()
    edges = [
        float(np.abs(np.diff(corrupt(image, n, np.random.default_rng(0)).astype(int), axis=1)).mean())
        for n in (11, 15, 20)
    ]
    assert edges[0] > edges[1] > edges[2]
