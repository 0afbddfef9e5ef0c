"""``lighting``: the lights brighter or darker, tinted and turned about the vertical; shadows from
level 3."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from libero_data.perturb.kinds.base import Drawn, Kind, register, rotation, sign, tint


@register
class Lighting(Kind):
    order = 6
    summary = "light intensity (brighter or darker), colour tint, direction; shadows from level 3"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {
        "intensity_change": (0.15, 0.30, 0.45, 0.60, 0.75),
        "tint": (0.05, 0.10, 0.20, 0.30, 0.40),
        "direction_deg": (10.0, 20.0, 30.0, 45.0, 60.0),
        "shadows": (False, False, True, True, True),
    }

    def sample(self, m: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
        hue = float(rng.uniform(0.0, 1.0))
        return {
            "intensity": 1.0 + sign(rng) * m["intensity_change"],
            "tint_rgb": tint(hue, m["tint"]),
            "direction_deg": sign(rng) * m["direction_deg"],
            "shadows": bool(m["shadows"]),
        }

    def apply_scene(self, raw: Any, p: Drawn) -> None:
        _relight(raw.sim.model._model, p.params)


def _relight(model: Any, params: dict[str, Any]) -> None:
    scale = float(params["intensity"]) * np.asarray(params["tint_rgb"], dtype=np.float64)
    model.light_diffuse[:] = np.clip(model.light_diffuse * scale, 0.0, 1.0)
    model.light_specular[:] = np.clip(model.light_specular * float(params["intensity"]), 0.0, 1.0)
    head = model.vis.headlight
    head.diffuse = np.clip(np.asarray(head.diffuse) * scale, 0.0, 1.0)
    head.ambient = np.clip(np.asarray(head.ambient) * scale, 0.0, 1.0)
    turn = rotation(np.array([0.0, 0.0, 1.0]), float(params["direction_deg"]))
    model.light_dir[:] = model.light_dir @ turn.T
    model.light_pos[:] = model.light_pos @ turn.T
    if params.get("shadows") and model.nlight:
        model.light_castshadow[0] = 1
