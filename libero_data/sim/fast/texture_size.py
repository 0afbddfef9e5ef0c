"""Textures halved to the scale a camera can show them at.

Each renderer's copy of the model also has its large textures halved until they are at most
:data:`TEXTURE_PER_IMAGE` times the image wide (a 4096x4096 bowl texture is 512x512 for
agentview and 1024x1024 for the wrist at 128 px). The fixed and the mounted cameras each have a
GL context of their own (:class:`~.images.FastImages`), and each would otherwise
hold every texture at full size: halved, the two contexts together hold about what one context
of full-size textures would. A camera never shows more of a texture than that width, so the
mip levels it samples, and with them the images, barely change (they are held to
:data:`~.images.FAST_MEAN_BOUND` with the rest of ``fast``:
tests/sim/test_fast_render_scenes.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Textures are halved (2x2 means) while wider than this many times the image, for the fixed
#: cameras (whose frame never shows more of a texture than that, so the mip levels sampled
#: stay) and for the mounted ones (a few centimetres from an object).
TEXTURE_PER_IMAGE = {"fixed": 4, "mounted": 8}


def shrink_textures(model: Any, cap: int) -> None:
    """Halve ``model``'s 2-D textures (in place: a render copy) while they are wider or taller
    than ``cap`` and even in both."""
    import mujoco

    for t in range(model.ntex):
        if model.tex_type[t] != mujoco.mjtTexture.mjTEXTURE_2D:
            continue
        width, height, channels = (
            int(model.tex_width[t]),
            int(model.tex_height[t]),
            int(model.tex_nchannel[t]),
        )
        start = int(model.tex_adr[t])
        size = width * height * channels
        image = np.asarray(model.tex_data[start : start + size]).reshape(height, width, channels)
        shrunk = halved(image, cap)
        if shrunk.shape[:2] != (height, width):
            model.tex_data[start : start + shrunk.size] = shrunk.reshape(-1)
            model.tex_height[t], model.tex_width[t] = shrunk.shape[:2]


def halved(image: np.ndarray, cap: int) -> np.ndarray:
    """``image`` (uint8, H x W x C) halved while wider or taller than ``cap`` and even in both.

    Each halving takes the mean of 2x2 pixels, so n halvings give the mean of each 2^n x 2^n
    block; successive float means are exact here (integers over powers of 4, far within float32's
    precision), so summing the blocks in integers and dividing once, rounded half to even, gives
    the same bytes as halving in float (tests/sim/test_texture_size.py) without a float copy of
    the texture at every level.
    """
    height, width = image.shape[:2]
    block = 1
    while (
        max(height // block, width // block) > cap
        and (height // block) % 2 == 0
        and (width // block) % 2 == 0
    ):
        block *= 2
    if block == 1:
        return image
    sums = image.astype(np.uint32)
    for _ in range(block.bit_length() - 1):  # 2x2 sums, level by level
        sums = sums[0::2, 0::2] + sums[1::2, 0::2] + sums[0::2, 1::2] + sums[1::2, 1::2]
    return np.round(sums / float(block * block)).astype(np.uint8)
