"""``noise``: Gaussian noise, blur and JPEG artefacts on the images, Gaussian noise on the
proprioception, seeded by the perturbation's seed and the simulator state itself (the same state
always gets the same noise; the state and the re-renderable clean frames stay exact)."""

from __future__ import annotations

import io
import zlib
from typing import Any, ClassVar

import numpy as np

from libero_data.perturb.kinds.base import Drawn, Kind, register

#: Proprioceptive observations that get noise (eef_quat stays a unit quaternion).
NOISY_STATE = ("state", "joint_pos", "gripper_state", "eef_pos")


@register
class Noise(Kind):
    order = 8
    summary = "Gaussian pixel noise, blur, JPEG quality of the images; Gaussian noise on the proprioception"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {
        "gaussian_sigma_255": (3.0, 6.0, 10.0, 15.0, 20.0),
        "blur_radius_px": (0.0, 0.4, 0.7, 1.0, 1.4),
        "jpeg_quality": (0, 85, 60, 40, 20),  # 0: no JPEG round trip
        "state_sigma": (0.002, 0.004, 0.008, 0.015, 0.025),
    }

    def sample(self, m: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
        return {k: (float(v) if isinstance(v, float) else int(v)) for k, v in m.items()}

    def observe(self, obs: dict[str, Any], p: Drawn, cameras: tuple[str, ...]) -> None:
        noise_observation(obs, p, cameras)


def noise_observation(obs: dict[str, Any], p: Drawn, cameras: tuple[str, ...]) -> None:
    """Noise the images and proprioception of ``obs`` in place (its ``sim_state`` stays clean)."""
    state = np.ascontiguousarray(obs["sim_state"])
    rng = np.random.default_rng([p.seed, zlib.crc32(state.tobytes())])
    params = p.params
    for camera in cameras:
        if camera in obs:
            obs[camera] = noisy_image(obs[camera], params, rng)
    sigma = float(params["state_sigma"])
    for key in NOISY_STATE:
        value = np.asarray(obs[key])
        obs[key] = (value + rng.normal(0.0, sigma, value.shape)).astype(value.dtype)


def noisy_image(image: np.ndarray, params: dict[str, Any], rng: np.random.Generator) -> np.ndarray:
    """Blur, then Gaussian noise, then a JPEG round trip (each where its level sets one)."""
    from PIL import Image, ImageFilter

    out = image
    if float(params["blur_radius_px"]) > 0:
        out = np.asarray(
            Image.fromarray(out).filter(ImageFilter.GaussianBlur(float(params["blur_radius_px"])))
        )
    noisy = out.astype(np.float32) + rng.normal(0.0, float(params["gaussian_sigma_255"]), out.shape)
    out = np.clip(np.round(noisy), 0, 255).astype(np.uint8)
    quality = int(params["jpeg_quality"])
    if quality > 0:
        buffer = io.BytesIO()
        Image.fromarray(out).save(buffer, format="JPEG", quality=quality)
        buffer.seek(0)
        with Image.open(buffer) as img:
            out = np.asarray(img.convert("RGB"), dtype=np.uint8)
    return np.ascontiguousarray(out)
