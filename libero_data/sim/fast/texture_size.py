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
        image = np.asarray(model.tex_data[start : start + width * height * channels], dtype=np.float32)
        image = image.reshape(height, width, channels)
        while max(image.shape[:2]) > cap and image.shape[0] % 2 == 0 and image.shape[1] % 2 == 0:
            h, w = image.shape[0] // 2, image.shape[1] // 2
            image = image.reshape(h, 2, w, 2, channels).mean(axis=(1, 3))
        if image.shape[:2] != (height, width):
            model.tex_data[start : start + image.size] = np.round(image).astype(np.uint8).reshape(-1)
            model.tex_height[t], model.tex_width[t] = image.shape[:2]
